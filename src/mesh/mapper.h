// The mapping hook (paper §6): the geometry and fields of a source sample expressed in the
// combinatorics of an element's canonical mesh, so that samples with different meshes can be
// blended vertex by vertex (Eq. 3). The builder calls it for every (term sample, element) pair
// and for the refinement test; the mesh-mapping module supplies the implementation for meshes of
// different combinatorics. Implementations must be deterministic and thread-safe (const).
#pragma once

#include <string>
#include <vector>

#include "mesh/sample.h"

namespace cadinterp::mesh {

/// A source sample in the canonical mesh's combinatorics.
struct MappedSample {
  std::vector<double> vertices;             ///< canonical #V by 3
  std::vector<std::vector<double>> fields;  ///< per field of the source, canonical layout
};

class Mapper {
 public:
  virtual ~Mapper() = default;
  /// Maps `source` onto `canonical` (both feasible). Returns false with `why` when it cannot
  /// (the element is then infeasible, with that message).
  virtual bool map(const Sample& source, const Sample& canonical, MappedSample& out,
                   std::string& why) const = 0;
  /// Name recorded in the asset's provenance.
  virtual const char* name() const = 0;
};

/// The mapping where combinatorics agree: vertex i is vertex i. Fails otherwise, naming the
/// difference, since any other correspondence needs the references (§6, src/mapping's
/// MeshMapper, the builder's default: build.h default_mapper()).
class IdentityMapper final : public Mapper {
 public:
  bool map(const Sample& source, const Sample& canonical, MappedSample& out,
           std::string& why) const override;
  const char* name() const override { return "identity"; }
};

}  // namespace cadinterp::mesh
