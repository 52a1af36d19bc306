// Quality of one mapping (the measured acceptance criteria), shared by the tests and
// `cadinterp-mapping-report pairs`: boundary geometry, tet quality, boundary-condition region
// areas, and field values against an independent truth at the mapped points.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "mesh/mapper.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

/// The true value of field `field` (components doubles into `value`) at point p of the source's
/// solid; false when unknown.
using FieldTruth = std::function<bool(int field, const double* p, double* value)>;

struct PairQuality {
  double hausdorff_max = 0;  ///< symmetric Hausdorff(mapped boundary, source boundary) / diag
  double hausdorff_p99 = 0;  ///< 99th percentile of the vertex distances (both ways) / diag
  /// Where hausdorff_max is reached: the vertex's position, whether it is a source vertex (far
  /// from the mapped boundary: a canonical triangle spans a bend of the source) or a mapped one
  /// (off the source boundary), and the face tag of a triangle at it (its own mesh's tags).
  double hausdorff_at[3] = {0, 0, 0};
  bool hausdorff_at_source = false;
  std::int32_t hausdorff_tag = -1;
  double min_scaled_jacobian = 0;
  std::size_t inverted = 0;
  double region_area_error = 0;  ///< max over regions |area mapped / area source - 1|
  double field_max = 0;          ///< per-vertex fields: max |mapped - truth| / truth range
  double field_p99 = 0;
};

/// `truth` may be empty (field errors stay 0).
PairQuality measure_pair(const mesh::Sample& source, const mesh::Sample& canonical,
                         const mesh::MappedSample& mapped, const FieldTruth& truth);

/// The error of one per-vertex field carried by a mapping: over the canonical vertices, the max
/// and the 99th percentile of max over components |mapped - reference| / the source field's
/// range.
struct FieldError {
  std::string name;
  double max = 0, p99 = 0;
};

/// The fields `mapped` carries from the source against the same-named per-vertex fields of
/// `reference`, a sample on the mapped mesh (the host's simulate there, field_transfer.h's
/// mesh_for_simulation):
/// one entry per source field that `reference` also has, in the source's order.
std::vector<FieldError> compare_fields(const mesh::Sample& source, const mesh::MappedSample& mapped,
                                       const mesh::Sample& reference);

/// Area of the triangles whose tag is in `tags` with positions `vertices`.
double tagged_area(const std::vector<double>& vertices, const mesh::Sample& mesh,
                   const std::vector<std::int32_t>& tags);

}  // namespace cadinterp::mapping
