// Fields carried along (paper §6, requirement 5): a canonical vertex takes the source's
// per-vertex values by barycentric interpolation at its mapped point (in the source triangle of
// the surface map for boundary vertices, in the source tet containing the mapped position for
// interior ones); a canonical tet takes the value of the source tet containing its mapped
// centroid.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mapping/surface.h"
#include "mesh/sample.h"

namespace cadinterp::mapping {

/// Point location in a tet mesh (uniform grid over the tets' bounding boxes).
class TetLocator {
 public:
  explicit TetLocator(const mesh::Sample& s);
  /// The tet containing p with its barycentric weights; a point outside the mesh gets the tet
  /// nearest in barycentric terms among those around it, weights clamped. -1 for an empty mesh.
  int locate(const double* p, double w[4]) const;

 private:
  const mesh::Sample& s_;
  double lo_[3] = {0, 0, 0}, cell_ = 1;
  int n_[3] = {1, 1, 1};
  std::vector<std::uint32_t> start_, items_;
  int cell_of(double x, int a) const;
  void weights(std::size_t t, const double* p, double w[4]) const;
};

/// Per source field, the canonical values. `surface_points[v]` is set for canonical boundary
/// vertices (`on_surface[v]`), `mapped` the canonical vertices' mapped positions (#V by 3).
std::vector<std::vector<double>> transfer_fields(const mesh::Sample& source,
                                                 const mesh::Sample& canonical,
                                                 const std::vector<double>& mapped,
                                                 const std::vector<char>& on_surface,
                                                 const std::vector<SurfacePoint>& surface_points,
                                                 const TetLocator& locator);

/// A mapped mesh as a host can simulate on it at the source's parameters: `positions` (the
/// canonical's vertices mapped, #V by 3), the canonical's tets and triangles, and each
/// triangle's tag replaced by one of the source's tags that lies in exactly the same named
/// regions (the canonical's own tag where it does; a face in no region gets a tag in none), so
/// that the host's boundary conditions at the source's parameters fall on the faces the
/// canonical's regions name (requirement 5: a force or fixture stays on its CAD face). False with
/// `why` where no source face lies in some canonical face's regions.
bool mesh_for_simulation(const mesh::Sample& source, const mesh::Sample& canonical,
                         const std::vector<double>& positions, mesh::Sample& out, std::string& why);

}  // namespace cadinterp::mapping
