// Comparing an evaluated mesh's per-vertex fields with a host's answer on another mesh. A mapped
// vertex (§6) may slide within its face, so vertex v of the evaluated mesh and vertex v of the
// host's need not be one point of the solid even where the two meshes share combinatorics. The
// builder's error model (MeshProblem::quantity_errors) and the accuracy measurements against the
// host (builder_e2e.h) share these, so that what the builder stores and what it is checked
// against measure one thing.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mapping/field_transfer.h"
#include "mesh/sample.h"

namespace cadinterp::builder {

/// The scale of a field's errors in the builder's measurements (its error model and its
/// calibration): the field's range (max - min of `values`), or, for a constant field, its
/// magnitude (1 if it is 0), so that a constant field's error is still relative. `values` must
/// not be empty. Thread-safe.
inline double field_error_scale(const std::vector<double>& values) {
  const auto mm = std::minmax_element(values.begin(), values.end());
  const double range = *mm.second - *mm.first;
  return range > 0 ? range : std::max(std::abs(*mm.first), 1.0);
}

/// An evaluated mesh's per-vertex values against `truth` located at its vertices: each vertex v
/// (at position(v, p)) is located in truth's mesh (barycentric in the tet containing it, the
/// nearest for a vertex a geometry error outside), and for each compared field k
/// (truth_fields[k], an index into truth.fields, or -1 to skip) and component c,
/// |value(k, v, c) - truth's value there| / scale[k] goes to note(k, v, error). Thread-safe as
/// far as the callbacks are; no failure (a vertex the locator cannot place is skipped, which
/// happens only for an empty truth mesh).
template <class Position, class Value, class Note>
void located_errors(const mesh::Sample& truth, std::uint32_t vertex_count,
                    const std::vector<int>& truth_fields, const std::vector<double>& scale,
                    Position position, Value value, Note note) {
  const mapping::TetLocator locator(truth);
  for (std::uint32_t v = 0; v < vertex_count; ++v) {
    double p[3], w[4];
    position(v, p);
    const int t = locator.locate(p, w);
    if (t < 0) continue;
    const std::uint32_t* tet = &truth.tets[4 * static_cast<std::size_t>(t)];
    for (std::size_t k = 0; k < truth_fields.size(); ++k) {
      if (truth_fields[k] < 0) continue;
      const mesh::Field& tf = truth.fields[static_cast<std::size_t>(truth_fields[k])];
      const auto C = static_cast<std::size_t>(tf.components);
      for (std::size_t c = 0; c < C; ++c) {
        double want = 0;
        for (std::size_t j = 0; j < 4; ++j) want += w[j] * tf.values[tet[j] * C + c];
        note(k, v, std::abs(value(k, v, c) - want) / scale[k]);
      }
    }
  }
}

}  // namespace cadinterp::builder
