// Writes an evaluated mesh for viewers: VTU (ParaView; the tet mesh with its fields), OBJ and
// glTF 2.0 (the boundary surface). Everything is written little-endian; the writers throw
// std::runtime_error naming the file when it cannot be written.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"

namespace cadinterp::cli {

/// A mesh as cadinterp_eval returns it (pointers borrowed, not owned).
struct ExportMesh {
  std::uint32_t vertex_count = 0;
  std::uint32_t tet_count = 0;
  std::uint32_t triangle_count = 0;
  const float* positions = nullptr;             ///< #V by 3
  const std::uint32_t* tets = nullptr;          ///< #T by 4
  const std::uint32_t* triangles = nullptr;     ///< #F by 3, outward
  const std::int32_t* triangle_tags = nullptr;  ///< #F (may be NULL)
  struct Field {
    std::string name;
    bool per_tet = false;
    int components = 1;
    const float* values = nullptr;  ///< #V (or #T) by components
  };
  std::vector<Field> fields;
  std::string generator = "cadinterp";  ///< recorded where the format has a place for it
};

/// The mesh and fields of one cadinterp_eval call (`fields`: the indices passed to it), ready to
/// export. Borrows the mesh's arrays: valid until the next call with its workspace.
ExportMesh export_mesh_of(const cadinterp_asset* asset, const cadinterp_mesh& mesh,
                          const int* fields, int field_count);

/// What a writer put in the file (for the tool's message and the tests).
struct ExportSummary {
  std::uint64_t vertices = 0;
  std::uint64_t cells = 0;  ///< tets (VTU) or triangles (OBJ, glTF)
  std::uint64_t bytes = 0;
};

enum class VtuEncoding { Ascii, Base64 };

/// VTK XML UnstructuredGrid: points, tets (VTK_TETRA = 10), per-vertex fields as PointData,
/// per-tet fields as CellData. Base64 is VTK's inline "binary" format with a UInt64 size header.
ExportSummary write_vtu(const std::string& path, const ExportMesh& mesh, VtuEncoding encoding);

/// Wavefront OBJ of the boundary triangles; only the vertices they use are written.
ExportSummary write_obj(const std::string& path, const ExportMesh& mesh);

/// glTF 2.0 of the boundary triangles (POSITION with min/max, 32-bit indices, per-vertex fields
/// of 1-4 components as application attributes "_NAME"); only the vertices they use are
/// written. A path ending in ".glb" gives the binary container, otherwise a .gltf with the
/// buffer embedded as a base64 data URI.
ExportSummary write_gltf(const std::string& path, const ExportMesh& mesh);

/// RFC 4648 base64 with padding.
std::string base64_encode(const void* data, std::size_t size);

}  // namespace cadinterp::cli
