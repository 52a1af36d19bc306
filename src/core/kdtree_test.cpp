#include "core/kdtree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>

namespace cadinterp::core {
namespace {

TEST(KdTree, AnisotropicSplitsKeepLevelsPerDirection) {
  KdTree t(3);
  const auto a = t.split(0, 2);
  const auto b = t.split(a[0], 0);
  const auto c = t.split(b[1], 0);
  EXPECT_EQ(t.leaves().size(), 4u);
  const KdTree::Node& n = t.node(c[0]);
  EXPECT_EQ(n.level[0], 2);
  EXPECT_EQ(n.level[1], 0);
  EXPECT_EQ(n.level[2], 1);
  EXPECT_EQ(n.box.lo[0], kUnit / 2);
  EXPECT_EQ(n.box.hi[0], kUnit / 4 * 3);
  EXPECT_EQ(n.box.hi[2], kUnit / 2);
}

TEST(KdTree, RejectsBadSplits) {
  EXPECT_THROW(KdTree(0), std::invalid_argument);
  EXPECT_THROW(KdTree(kMaxDim + 1), std::invalid_argument);
  KdTree t(2);
  t.split(0, 1);
  EXPECT_THROW(t.split(0, 0), std::invalid_argument) << "not a leaf";
  EXPECT_THROW(t.split(1, 2), std::invalid_argument) << "no such direction";
  int leaf = 1;
  for (int l = 1; l < kMaxLevel; ++l) leaf = t.split(leaf, 1)[0];
  EXPECT_THROW(t.split(leaf, 1), std::invalid_argument) << "deeper than kMaxLevel";
}

TEST(KdTree, QueriesOnFacesAndCorners) {
  KdTree t(2);
  const auto a = t.split(0, 0);
  const auto b = t.split(a[1], 1);
  // Centre of the domain lies on all three leaves.
  std::vector<int> out;
  IPoint centre{};
  centre[0] = centre[1] = kUnit / 2;
  t.leaves_containing(centre, out);
  std::sort(out.begin(), out.end());
  EXPECT_EQ(out, (std::vector<int>{a[0], b[0], b[1]}));
  // Overlap needs interior: b[0] and b[1] touch a[0] but only a[0]'s interior meets itself.
  out.clear();
  t.leaves_overlapping(t.node(a[0]).box, out);
  EXPECT_EQ(out, std::vector<int>{a[0]});
  out.clear();
  t.leaves_touching(t.node(a[0]).box, out);
  EXPECT_EQ(out.size(), 3u);
  const double u[2] = {0.5, 0.5};
  EXPECT_EQ(t.locate_unit(u), b[1]);
}

}  // namespace
}  // namespace cadinterp::core
