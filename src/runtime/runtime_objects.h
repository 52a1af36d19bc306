// The objects behind the C ABI's opaque handles: cadinterp_asset (an opened file, its metadata
// as C strings, its element cache) and cadinterp_workspace (one thread's scratch and the element
// its last call evaluated). Internal to libcadinterp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cadinterp/cadinterp.h"
#include "core/compiled_basis.h"
#include "format/asset_reader.h"
#include "runtime/element_cache.h"

namespace cadinterp::runtime {

struct FieldSlot {
  std::string name;
  cadinterp_field_location location;
  int components;
  double max_abs_error;
  std::string unit;  // "" when the asset gives none (format 1.0, or a field without a unit)
};

// A per-sample scalar output (format 1.3): one value per basis sample.
struct OutputSlot {
  std::string name, unit;
  std::vector<double> values;
};

struct RegionSlot {
  std::string name, kind;
  std::vector<std::int32_t> tags;
};

}  // namespace cadinterp::runtime

struct cadinterp_asset {
  std::unique_ptr<cadinterp::format::AssetReader> reader;
  std::vector<std::string> names, units;
  std::vector<cadinterp::runtime::FieldSlot> fields;
  std::vector<cadinterp::runtime::RegionSlot> regions;
  std::vector<cadinterp::runtime::OutputSlot> outputs;
  std::string builder_version, host, options;
  std::vector<std::vector<double>> infeasible_x;  // host failures recorded by the builder
  std::vector<std::string> infeasible_message;
  mutable cadinterp::runtime::ElementCache cache;
};

struct cadinterp_workspace {
  const cadinterp_asset* asset = nullptr;
  cadinterp::core::EvalWorkspace basis_ws;
  std::shared_ptr<const cadinterp::runtime::CachedElement> element;  // keeps topology alive
  // The element's field arrays when the last call needed them (prepare), else null.
  const std::vector<cadinterp::format::DecodedArray<float>>* fields = nullptr;
  std::vector<const float*> arrays;
  std::vector<float> weights;
  std::vector<float> positions, dpositions;
  std::vector<std::vector<float>> field_values, field_grads;
  std::vector<const float*> field_ptrs, field_grad_ptrs;
  std::vector<double> adjoint;        // #V by 3 scratch for mass-property gradients
  std::vector<double> dots;           // per term
  std::vector<double> field_adjoint;  // per vertex or tet: d(integral)/d(field value)
  std::string error;
};

namespace cadinterp::runtime {

// An asset over `reader`, its metadata copied out of the index as C strings. Throws on failure.
std::unique_ptr<cadinterp_asset> make_asset(std::unique_ptr<format::AssetReader> reader);

// Records `msg` as the workspace's message (if there is a workspace) and returns s.
inline cadinterp_status fail(cadinterp_workspace* ws, cadinterp_status s, const std::string& msg) {
  if (ws) ws->error = msg;
  return s;
}

// Offset of field f in an element's concatenated field array (fields in index order).
std::size_t field_offset(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt);
// Number of floats of field f in an element of nv vertices and nt tets.
std::size_t field_size(const cadinterp_asset& a, int f, std::size_t nv, std::size_t nt);

}  // namespace cadinterp::runtime
