// The cubic case's neighbour transfer (paper §5.3, Fig. 15, requirement 6). A cubic element l
// also needs samples x_k of an adjacent element l', which are stored in l's neighbour's
// combinatorics (p_k^{l'}). A sample x_s on the boundary of both elements exists in both
// combinatorics with the same geometry (p_s^{l'} and p_s^l); the map F: p_s^l -> p_s^{l'} by
// barycentric coordinates (each vertex of p_s^l located in a tet of p_s^{l'}) is computed once
// and applied to every p_k^{l'}, giving p_k^l without a second homeomorphic mapping: each sample
// goes through the §6 mapping once, so errors do not accumulate.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mapper.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

class NeighbourBridge {
 public:
  /// `neighbour` is l''s canonical mesh (tets) with `shared_in_neighbour` the vertices of
  /// p_s^{l'}; `element` is l's canonical mesh (tets) with `shared_in_element` the vertices of
  /// p_s^l. Fails (ok() false, why()) when a mesh is empty or sizes disagree.
  NeighbourBridge(const mesh::Sample& neighbour, const std::vector<double>& shared_in_neighbour,
                  const mesh::Sample& element, const std::vector<double>& shared_in_element);
  bool ok() const { return why_.empty(); }
  const std::string& why() const { return why_; }

  /// p_k^l from p_k^{l'} (vertices and fields in l''s combinatorics; field layouts as
  /// `neighbour`'s fields). False with `why` when the bridge is not ok or sizes disagree.
  bool apply(const mesh::MappedSample& in_neighbour, mesh::MappedSample& out,
             std::string& why) const;

 private:
  const mesh::Sample& neighbour_;
  const mesh::Sample& element_;
  std::vector<std::uint32_t> vertex_tet_;  // per element vertex: the neighbour tet
  std::vector<double> vertex_w_;           // 4 weights per element vertex
  std::vector<std::uint32_t> tet_tet_;     // per element tet: the neighbour tet at its centroid
  std::string why_;
};

}  // namespace cadinterp::mapping
