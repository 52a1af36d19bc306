// What the two samples share (correspondence.h): CAD edge keys and the layout's cuts, on
// constructed paths and the tube of mapping_test_util.h.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "mapping/correspondence.h"
#include "mapping/mapping_test_util.h"
#include "mapping/surface.h"
#include "mesh/sample.h"

namespace {

using namespace cadinterp;
using namespace cadinterp::mapping_test;

TEST(MeshMapper, PathEdgeKeysNameTheCadEdge) {
  mesh::Path p;
  p.a = {0, 3, 2, 7, 11};
  p.b = {1, 7, 3, 4, -1, 0};
  EXPECT_EQ(mapping::path_edge_key(p), (mapping::Id{1, 7, 3, 4}));
  mesh::Path q;
  q.a = {0, 4, 1};
  q.b = {0, 3, 1};
  EXPECT_EQ(mapping::path_edge_key(q), (mapping::Id{2, 3, 0, 3, 1, 0, 4, 1}));
}

// A CAD edge of one sample only (faces that merge across the parameter box) is no layout cut: its
// mesh edges are found on its path by their midpoints. A host may put mesh vertices on the curve
// between the path's nodes (the OpenCASCADE host's bisection, projected onto the B-rep), off
// the polyline's chords. The tube's top outer circle (16 mesh edges) keeps every other node of
// its polyline, so 8 of its vertices lie 0.15 (a tenth of the chord) off it; with the circle's
// edge key not common, none of its mesh edges is cut, as with the whole polyline.
TEST(LayoutCuts, UnsharedEdgeWhoseMeshVerticesLieOffItsPolylineIsNotCut) {
  const tube::Shape shape{1.0, 2.0, 3.0, 16, 8};
  for (const bool thin : {false, true}) {
    mesh::Sample s = tube::make(shape);
    std::set<mapping::Id> common = mapping::correspond(s, s).common_edges;
    std::size_t circle_paths = 0;
    for (mesh::Path& p : s.paths) {
      std::vector<double>& pl = p.polyline;
      bool top_outer = true;
      for (std::size_t i = 0; i < pl.size(); i += 3)
        top_outer = top_outer && pl[i + 2] == shape.height &&
                    std::abs(std::hypot(pl[i], pl[i + 1]) - shape.r_out) < 1e-12;
      if (!top_outer) continue;
      common.erase(mapping::path_edge_key(p));
      ++circle_paths;
      ASSERT_EQ(pl.size(), 15u);  // 5 nodes: a quarter of the circle
      if (thin) pl = {pl[0], pl[1], pl[2], pl[6], pl[7], pl[8], pl[12], pl[13], pl[14]};
    }
    ASSERT_EQ(circle_paths, 4u);
    ASSERT_EQ(mesh::validate(s), "");
    mapping::Surface surf;
    std::string why;
    ASSERT_TRUE(mapping::build_surface(s, surf, why)) << why;
    const std::vector<char> cuts = mapping::layout_cuts(surf, common, 1e-9 * s.bbox_diagonal());
    std::size_t on_circle = 0, cut = 0;
    for (int h = 0; h < 3 * surf.triangles(); ++h) {
      const int t = surf.twin[std::size_t(h)];
      const std::int32_t a = s.triangle_tags[std::size_t(h / 3)];
      if (t < 0 || a != 1 || s.triangle_tags[std::size_t(t / 3)] != 3) continue;
      ++on_circle;
      cut += cuts[std::size_t(h)] ? 1 : 0;
    }
    EXPECT_EQ(on_circle, 16u) << (thin ? "thinned" : "whole");
    EXPECT_EQ(cut, 0u) << (thin ? "thinned" : "whole");
  }
}

}  // namespace
