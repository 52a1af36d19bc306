#include "mapping/neighbour_transfer.h"

#include "mapping/field_transfer.h"

namespace cadinterp::mapping {

NeighbourBridge::NeighbourBridge(const mesh::Sample& neighbour,
                                 const std::vector<double>& shared_in_neighbour,
                                 const mesh::Sample& element,
                                 const std::vector<double>& shared_in_element)
    : neighbour_(neighbour), element_(element) {
  if (neighbour.tet_count() == 0 || element.tet_count() == 0) {
    why_ = "neighbour transfer: empty mesh";
    return;
  }
  if (shared_in_neighbour.size() != neighbour.vertices.size() ||
      shared_in_element.size() != element.vertices.size()) {
    why_ = "neighbour transfer: the shared sample's vertices do not match the meshes";
    return;
  }
  // The shared sample in the neighbour's combinatorics, as a mesh to locate points in.
  mesh::Sample bridge;
  bridge.vertices = shared_in_neighbour;
  bridge.tets = neighbour.tets;
  const TetLocator locator(bridge);
  const std::size_t V = element.vertex_count(), T = element.tet_count();
  vertex_tet_.resize(V);
  vertex_w_.resize(4 * V);
  for (std::size_t v = 0; v < V; ++v) {
    const int t = locator.locate(&shared_in_element[3 * v], &vertex_w_[4 * v]);
    if (t < 0) {
      why_ = "neighbour transfer: a vertex could not be located";
      return;
    }
    vertex_tet_[v] = static_cast<std::uint32_t>(t);
  }
  tet_tet_.resize(T);
  for (std::size_t t = 0; t < T; ++t) {
    double c[3] = {0, 0, 0}, w[4];
    for (int i = 0; i < 4; ++i)
      for (int a = 0; a < 3; ++a)
        c[a] += 0.25 * shared_in_element[3 * std::size_t(element.tets[4 * t + std::size_t(i)]) +
                                         std::size_t(a)];
    const int n = locator.locate(c, w);
    tet_tet_[t] = static_cast<std::uint32_t>(n < 0 ? 0 : n);
  }
}

bool NeighbourBridge::apply(const mesh::MappedSample& in, mesh::MappedSample& out,
                            std::string& why) const {
  if (!ok()) {
    why = why_;
    return false;
  }
  if (in.vertices.size() != neighbour_.vertices.size() ||
      in.fields.size() != neighbour_.fields.size()) {
    why = "neighbour transfer: the sample is not in the neighbour's combinatorics";
    return false;
  }
  const std::size_t V = element_.vertex_count(), T = element_.tet_count();
  auto blend = [&](const std::vector<double>& src, std::size_t C, std::vector<double>& dst) {
    dst.assign(V * C, 0.0);
    for (std::size_t v = 0; v < V; ++v) {
      const std::uint32_t* q = &neighbour_.tets[4 * std::size_t(vertex_tet_[v])];
      for (int i = 0; i < 4; ++i)
        for (std::size_t c = 0; c < C; ++c)
          dst[v * C + c] += vertex_w_[4 * v + std::size_t(i)] * src[q[i] * C + c];
    }
  };
  blend(in.vertices, 3, out.vertices);
  out.fields.assign(in.fields.size(), {});
  for (std::size_t f = 0; f < in.fields.size(); ++f) {
    const mesh::Field& desc = neighbour_.fields[f];
    const auto C = static_cast<std::size_t>(desc.components);
    if (desc.location == 0) {
      blend(in.fields[f], C, out.fields[f]);
    } else {
      out.fields[f].assign(T * C, 0.0);
      for (std::size_t t = 0; t < T; ++t)
        for (std::size_t c = 0; c < C; ++c)
          out.fields[f][t * C + c] = in.fields[f][std::size_t(tet_tet_[t]) * C + c];
    }
  }
  return true;
}

}  // namespace cadinterp::mapping
