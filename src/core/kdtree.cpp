#include "core/kdtree.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cadinterp::core {

KdTree::KdTree(int K) : K_(K) {
  if (K < 1 || K > kMaxDim)
    throw std::invalid_argument("KdTree: dimension " + std::to_string(K) + " outside 1.." +
                                std::to_string(kMaxDim));
  Node root;
  for (int d = 0; d < K; ++d) root.box.hi[d] = kUnit;
  nodes_.push_back(root);
  leaves_.push_back(0);
  leaf_slot_.push_back(0);
}

std::array<int, 2> KdTree::split(int id, int dir) {
  if (id < 0 || id >= node_count() || !is_leaf(id))
    throw std::invalid_argument("KdTree::split: node " + std::to_string(id) + " is not a leaf");
  if (dir < 0 || dir >= K_)
    throw std::invalid_argument("KdTree::split: direction " + std::to_string(dir) +
                                " out of range");
  if (node(id).level[dir] >= kMaxLevel)
    throw std::invalid_argument("KdTree::split: maximum level reached");

  const Node parent = node(id);
  const Coord mid = parent.box.lo[dir] + (parent.box.hi[dir] - parent.box.lo[dir]) / 2;
  std::array<int, 2> kids{};
  for (int side = 0; side < 2; ++side) {
    Node c;
    c.box = parent.box;
    (side == 0 ? c.box.hi : c.box.lo)[dir] = mid;
    c.level = parent.level;
    ++c.level[dir];
    c.parent = id;
    kids[side] = node_count();
    nodes_.push_back(c);
    leaf_slot_.push_back(-1);
  }
  Node& p = nodes_[static_cast<std::size_t>(id)];
  p.child[0] = kids[0];
  p.child[1] = kids[1];
  p.split_dir = static_cast<std::int8_t>(dir);

  const int slot = leaf_slot_[static_cast<std::size_t>(id)];
  leaves_[static_cast<std::size_t>(slot)] = kids[0];
  leaf_slot_[static_cast<std::size_t>(kids[0])] = slot;
  leaf_slot_[static_cast<std::size_t>(id)] = -1;
  leaf_slot_[static_cast<std::size_t>(kids[1])] = static_cast<int>(leaves_.size());
  leaves_.push_back(kids[1]);
  return kids;
}

// Depth-first descent into every node whose box satisfies pred; boxes are nested, so a child
// can only satisfy a containment/intersection predicate if its parent does.
template <class Pred>
void KdTree::collect(Pred&& pred, std::vector<int>& out) const {
  int stack[2 * (kMaxDim * kMaxLevel + 1)];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int id = stack[--top];
    const Node& n = node(id);
    if (!pred(n.box)) continue;
    if (n.child[0] < 0) {
      out.push_back(id);
    } else {
      stack[top++] = n.child[1];
      stack[top++] = n.child[0];
    }
  }
}

void KdTree::leaves_containing(const IPoint& p, std::vector<int>& out) const {
  collect([&](const IBox& b) { return box_contains(b, p, K_); }, out);
}

void KdTree::leaves_containing(const double* p, std::vector<int>& out) const {
  collect(
      [&](const IBox& b) {
        for (int d = 0; d < K_; ++d)
          if (p[d] < static_cast<double>(b.lo[d]) || p[d] > static_cast<double>(b.hi[d]))
            return false;
        return true;
      },
      out);
}

void KdTree::leaves_touching(const IBox& q, std::vector<int>& out) const {
  collect([&](const IBox& b) { return boxes_touch(b, q, K_); }, out);
}

void KdTree::leaves_overlapping(const IBox& q, std::vector<int>& out) const {
  collect([&](const IBox& b) { return boxes_overlap(b, q, K_); }, out);
}

int KdTree::locate_unit(const double* u) const {
  for (int d = 0; d < K_; ++d)
    if (!(u[d] >= 0.0 && u[d] <= 1.0)) return -1;  // also rejects NaN
  int id = 0;
  while (!is_leaf(id)) {
    const Node& n = node(id);
    const int d = n.split_dir;
    // The split coordinate is dyadic, hence exact in double: the comparison is exact.
    const double mid = to_unit(node(n.child[1]).box.lo[d]);
    id = (u[d] >= mid) ? n.child[1] : n.child[0];
  }
  return id;
}

}  // namespace cadinterp::core
