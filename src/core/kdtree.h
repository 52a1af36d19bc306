// K-d tree over the integer unit box [0, kUnit]^K with anisotropic splits (paper §4).
//
// Every split halves one element along one direction, so each element has its own level per
// direction and all faces stay on the dyadic integer grid.
#pragma once

#include <cstdint>
#include <vector>

#include "core/grid.h"

namespace cadinterp::core {

class KdTree {
 public:
  struct Node {
    IBox box;
    std::array<std::int8_t, kMaxDim> level{};  ///< per-direction level (width = kUnit >> level)
    std::int32_t parent = -1;
    std::int32_t child[2] = {-1, -1};  ///< lower and upper half; -1 for a leaf
    std::int8_t split_dir = -1;        ///< -1 for a leaf
  };

  /// A tree with one root element covering the unit box in K directions, 1 <= K <= kMaxDim.
  explicit KdTree(int K);

  int dim() const { return K_; }
  const Node& node(int id) const { return nodes_[static_cast<std::size_t>(id)]; }
  int node_count() const { return static_cast<int>(nodes_.size()); }
  bool is_leaf(int id) const { return node(id).child[0] < 0; }

  /// Leaf node ids, in creation order (a split replaces the parent by its lower child and appends
  /// the upper child), so iteration is deterministic.
  const std::vector<int>& leaves() const { return leaves_; }

  /// Splits leaf `id` at the midpoint of direction `dir`. Returns the two children (lower, upper).
  /// Throws std::invalid_argument if `id` is not a leaf or the level would exceed kMaxLevel.
  std::array<int, 2> split(int id, int dir);

  /// Leaves whose closed box contains p (up to 2^K when p lies on faces), appended to `out`.
  void leaves_containing(const IPoint& p, std::vector<int>& out) const;
  /// As above for a real point given in integer units (may be non-integral).
  void leaves_containing(const double* p, std::vector<int>& out) const;
  /// Leaves whose closed box shares a point with the closed box b, appended to `out`.
  void leaves_touching(const IBox& b, std::vector<int>& out) const;
  /// Leaves whose interior intersects the interior of b, appended to `out`.
  void leaves_overlapping(const IBox& b, std::vector<int>& out) const;

  /// The leaf containing point u (unit coordinates, inside [0,1]^K). A point on a face goes to
  /// the upper side, except on the domain's upper boundary where it stays in the last element;
  /// the choice is a pure function of u. Returns -1 when u is outside [0,1]^K or not finite.
  int locate_unit(const double* u) const;

 private:
  template <class Pred>
  void collect(Pred&& pred, std::vector<int>& out) const;

  int K_;
  std::vector<Node> nodes_;
  std::vector<int> leaves_;
  std::vector<int> leaf_slot_;  ///< node id -> position in leaves_ (or -1)
};

}  // namespace cadinterp::core
