/* WebAssembly-only additions to the C ABI, used by cadinterp.mjs:
 * - the struct layouts cadinterp.mjs reads from memory, checked at compile time (a change of
 *   cadinterp.h that moves a member fails the build here instead of returning garbage in JS);
 * - the heap's bytes in use, for the leak tests (test/memory.test.mjs). */
#include <malloc.h>
#include <stddef.h>

#include "cadinterp/cadinterp.h"

#define CHECK(cond) _Static_assert(cond, #cond)
/* wasm32: 4-byte pointers, 8-byte aligned doubles. The offsets are those of cadinterp.mjs. */
CHECK(sizeof(void*) == 4);
CHECK(offsetof(cadinterp_parameter_info, unit) == 4);
CHECK(offsetof(cadinterp_parameter_info, lower) == 8);
CHECK(offsetof(cadinterp_parameter_info, upper) == 16);
CHECK(sizeof(cadinterp_parameter_info) == 24);
CHECK(offsetof(cadinterp_field_info, location) == 4);
CHECK(offsetof(cadinterp_field_info, components) == 8);
CHECK(offsetof(cadinterp_field_info, max_abs_error) == 16);
CHECK(sizeof(cadinterp_field_info) == 24);
CHECK(offsetof(cadinterp_region_info, kind) == 4);
CHECK(offsetof(cadinterp_region_info, face_tags) == 8);
CHECK(offsetof(cadinterp_region_info, face_tag_count) == 12);
CHECK(offsetof(cadinterp_provenance, host) == 4);
CHECK(offsetof(cadinterp_provenance, options) == 8);
CHECK(offsetof(cadinterp_mesh, vertex_count) == 4);
CHECK(offsetof(cadinterp_mesh, tet_count) == 8);
CHECK(offsetof(cadinterp_mesh, triangle_count) == 12);
CHECK(offsetof(cadinterp_mesh, tets) == 16);
CHECK(offsetof(cadinterp_mesh, triangles) == 20);
CHECK(offsetof(cadinterp_mesh, triangle_tags) == 24);
CHECK(offsetof(cadinterp_mesh, positions) == 28);
CHECK(offsetof(cadinterp_mesh, fields) == 32);
CHECK(sizeof(cadinterp_mesh) == 36);
CHECK(offsetof(cadinterp_mesh_grad, vertex_count) == 4);
CHECK(offsetof(cadinterp_mesh_grad, positions) == 8);
CHECK(offsetof(cadinterp_mesh_grad, dpositions) == 12);
CHECK(offsetof(cadinterp_mesh_grad, dfields) == 16);
CHECK(sizeof(cadinterp_mesh_grad) == 20);
CHECK(offsetof(cadinterp_properties, mass) == 8);
CHECK(offsetof(cadinterp_properties, area) == 16);
CHECK(offsetof(cadinterp_properties, frontal_area) == 24);
CHECK(offsetof(cadinterp_properties, centroid) == 32);
CHECK(offsetof(cadinterp_properties, inertia) == 56);
CHECK(sizeof(cadinterp_properties) == 128);

/** Layout version cadinterp.mjs expects (bumped with the offsets above). */
CADINTERP_API int cadinterp_wasm_layout_version(void) { return 1; }

/** Bytes of the heap in use by malloc (allocated, not freed). */
CADINTERP_API size_t cadinterp_wasm_heap_in_use(void) { return (size_t)mallinfo().uordblks; }
