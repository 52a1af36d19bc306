#include "core/basis.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cadinterp::core {

Basis::Basis(int K, Degree degree) : degree_(degree), tree_(K) {
  leaf_samples_.resize(1);
  leaf_bsplines_.resize(1);
  for (int mask = 0; mask < (1 << K); ++mask) {
    IPoint p{};
    for (int d = 0; d < K; ++d) p[d] = ((mask >> d) & 1) ? kUnit : 0;
    add_sample(p);
  }

  // Level-0 B-splines: linear centres {0, 1}, cubic centres {-1, 0, 1, 2} per direction. Each is
  // assigned the multilinear weights of its centre with respect to the corners; for a centre
  // outside [0,1] these extrapolate (see basis.h), so the result reproduces linear functions.
  const int radius = support_radius(degree);
  const int per_dir = 2 * radius;
  int combos = 1;
  for (int d = 0; d < K; ++d) combos *= per_dir;
  for (int c = 0; c < combos; ++c) {
    BsplineKey key;
    std::array<double, kMaxDim> t{};  // centre in unit coordinates
    int rest = c;
    for (int d = 0; d < K; ++d) {
      const int i = rest % per_dir - (radius - 1);
      rest /= per_dir;
      key.centre[d] = static_cast<Coord>(i) * kUnit;
      t[static_cast<std::size_t>(d)] = static_cast<double>(i);
    }
    std::vector<Coefficient> coeffs;
    for (int mask = 0; mask < (1 << K); ++mask) {
      double w = 1.0;
      for (int d = 0; d < K; ++d) w *= ((mask >> d) & 1) ? t[d] : 1.0 - t[d];
      if (w != 0.0) coeffs.emplace_back(mask, w);  // corner `mask` has sample id `mask`
    }
    set_coeffs(bspline_id(key), std::move(coeffs));
  }
}

int Basis::find_sample(const IPoint& p) const {
  const auto it = sample_id_.find(p);
  return it == sample_id_.end() ? -1 : it->second;
}

int Basis::add_sample(const IPoint& p) {
  const int id = sample_count();
  samples_.push_back(p);
  sample_id_.emplace(p, id);
  std::vector<int> holders;
  tree_.leaves_containing(p, holders);
  for (int leaf : holders)
    leaf_samples_[static_cast<std::size_t>(leaf)].push_back(id);  // stays sorted
  return id;
}

bool Basis::is_sample_point(const IPoint& p, std::vector<int>& holders) const {
  // p is a corner of some common cuboid iff it is a corner of the intersection of all leaves
  // containing it, i.e. iff in every direction one of those leaves has a face through p.
  holders.clear();
  tree_.leaves_containing(p, holders);
  if (holders.empty()) return false;
  for (int d = 0; d < dim(); ++d) {
    bool on_face = false;
    for (int leaf : holders) {
      const IBox& b = tree_.node(leaf).box;
      if (b.lo[d] == p[d] || b.hi[d] == p[d]) {
        on_face = true;
        break;
      }
    }
    if (!on_face) return false;
  }
  return true;
}

int Basis::bspline_id(const BsplineKey& key) {
  const auto it = bspline_id_.find(key);
  if (it != bspline_id_.end()) return it->second;
  const int id = static_cast<int>(bsplines_.size());
  bsplines_.push_back(Bspline{key, support_box(key, degree_, dim()), {}, true});
  bspline_id_.emplace(key, id);
  ++live_bsplines_;
  index_bspline(id, true);
  return id;
}

void Basis::index_bspline(int b, bool add) {
  std::vector<int> leaves;
  tree_.leaves_overlapping(bsplines_[static_cast<std::size_t>(b)].support, leaves);
  for (int leaf : leaves) {
    auto& list = leaf_bsplines_[static_cast<std::size_t>(leaf)];
    // Each list is in ascending id order: a new B-spline takes the largest id yet and goes to
    // the back, and a split's children filter their parent's list in order (refine.cpp). So
    // the removal finds b by binary search (a linear search showed in the cubic fallback test's
    // profile at 18 %).
    if (add)
      list.push_back(b);
    else
      list.erase(std::lower_bound(list.begin(), list.end(), b));
  }
}

void Basis::set_coeffs(int b, std::vector<Coefficient> coeffs) {
  Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
  coeffs.erase(
      std::remove_if(coeffs.begin(), coeffs.end(),
                     [](const Coefficient& c) { return std::abs(c.second) < kCoeffEpsilon; }),
      coeffs.end());
  std::sort(coeffs.begin(), coeffs.end());
  bs.coeffs = std::move(coeffs);
  bs.changed_in = refines_;
  if (bs.coeffs.empty()) kill_bspline(b);
}

void Basis::kill_bspline(int b) {
  Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
  if (!bs.alive) return;
  index_bspline(b, false);
  bs.coeffs.clear();
  bs.alive = false;
  bspline_id_.erase(bs.key);
  --live_bsplines_;
}

std::vector<int> Basis::bsplines_overlapping(const std::vector<int>& leaves) const {
  // Sorting the union costs O(n log n) in the B-splines found; a seen-mask over every B-spline
  // ever created would cost O(created) per call, which dominated element_basis on deep cubic
  // trees.
  std::vector<int> out;
  for (int leaf : leaves) {
    const auto& list = leaf_bsplines_[static_cast<std::size_t>(leaf)];
    out.insert(out.end(), list.begin(), list.end());
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool Basis::overlaps_domain(const BsplineKey& key) const {
  IBox domain;
  for (int d = 0; d < dim(); ++d) domain.hi[d] = kUnit;
  return boxes_overlap(support_box(key, degree_, dim()), domain, dim());
}

bool Basis::sample_is_local(int k, const std::vector<int>& support_leaves,
                            HolderCache& holders) const {
  const IPoint& x = sample(k);
  const int K = dim();
  if (degree_ == Degree::Linear) {
    for (int n : support_leaves)
      if (!box_contains(tree_.node(n).box, x, K)) return false;
    return true;
  }
  // Cubic: k in Bbar(n) iff a leaf holding x_k touches n; n itself holds x_k in the common case,
  // which needs no search among the (up to 2^K) holders.
  auto it = holders.end();
  for (int n : support_leaves) {
    const IBox& nb = tree_.node(n).box;
    if (box_contains(nb, x, K)) continue;
    if (it == holders.end()) {
      it = holders.find(k);
      if (it == holders.end()) {
        it = holders.emplace(k, std::vector<int>()).first;
        tree_.leaves_containing(x, it->second);
      }
    }
    bool near = false;
    for (int m : it->second)
      if (boxes_touch(tree_.node(m).box, nb, K)) {
        near = true;
        break;
      }
    if (!near) return false;
  }
  return true;
}

ElementBasis Basis::element_basis(int leaf) const {
  if (leaf < 0 || leaf >= tree_.node_count() || !tree_.is_leaf(leaf))
    throw std::invalid_argument("Basis::element_basis: not a leaf");
  ElementBasis eb;
  eb.leaf = leaf;
  const std::vector<int> ids = bsplines_overlapping({leaf});
  std::vector<char> seen(samples_.size(), 0);
  for (int b : ids)
    for (const auto& [k, a] : bsplines_[static_cast<std::size_t>(b)].coeffs)
      if (!seen[static_cast<std::size_t>(k)]) {
        seen[static_cast<std::size_t>(k)] = 1;
        eb.terms.push_back(k);
      }
  std::sort(eb.terms.begin(), eb.terms.end());
  eb.bsplines.reserve(ids.size());
  eb.col_begin.push_back(0);
  for (int b : ids) {
    const Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
    eb.bsplines.push_back(bs.key);
    for (const auto& [k, a] : bs.coeffs) {
      const auto t = std::lower_bound(eb.terms.begin(), eb.terms.end(), k) - eb.terms.begin();
      eb.col_term.push_back(static_cast<int>(t));
      eb.col_value.push_back(a);
    }
    eb.col_begin.push_back(static_cast<int>(eb.col_term.size()));
  }
  return eb;
}

bool Basis::corner_fallback_basis(int leaf, ElementBasis* out) const {
  if (degree_ != Degree::Cubic || leaf < 0 || leaf >= tree_.node_count() || !tree_.is_leaf(leaf))
    return false;
  const int K = dim();
  const KdTree::Node& node = tree_.node(leaf);
  const IBox& box = node.box;
  const int corners = 1 << K;
  std::vector<std::pair<int, int>> by_sample;  // (sample id, corner bits: 1 = upper in d)
  for (int m = 0; m < corners; ++m) {
    const int k = find_sample(box_corner(box, m, K));
    if (k < 0) return false;
    by_sample.emplace_back(k, m);
  }
  std::sort(by_sample.begin(), by_sample.end());
  ElementBasis eb;
  eb.leaf = leaf;
  std::vector<int> term_of_corner(static_cast<std::size_t>(corners));
  for (std::size_t t = 0; t < by_sample.size(); ++t) {
    eb.terms.push_back(by_sample[t].first);
    term_of_corner[static_cast<std::size_t>(by_sample[t].second)] = static_cast<int>(t);
  }
  // Per direction, B-spline j = 0..3 is centred at lo + (j - 1) w (w = hi - lo, the element's
  // knot spacing at its level); the lower corner's linear weight there is 2, 1, 0, -1 and the
  // upper corner's -1, 0, 1, 2.
  static constexpr double kLowerWeight[4] = {2.0, 1.0, 0.0, -1.0};
  int count = 1;
  for (int d = 0; d < K; ++d) count *= 4;
  eb.col_begin.push_back(0);
  for (int i = 0; i < count; ++i) {
    BsplineKey key;
    int j[kMaxDim];
    for (int d = 0, r = i; d < K; ++d, r /= 4) {
      j[d] = r % 4;
      key.level[static_cast<std::size_t>(d)] = node.level[static_cast<std::size_t>(d)];
      key.centre[static_cast<std::size_t>(d)] = box.lo[d] + (j[d] - 1) * (box.hi[d] - box.lo[d]);
    }
    for (int m = 0; m < corners; ++m) {
      double a = 1.0;
      for (int d = 0; d < K && a != 0.0; ++d) a *= kLowerWeight[(m >> d) & 1 ? 3 - j[d] : j[d]];
      if (a == 0.0) continue;
      eb.col_term.push_back(term_of_corner[static_cast<std::size_t>(m)]);
      eb.col_value.push_back(a);
    }
    eb.bsplines.push_back(key);
    eb.col_begin.push_back(static_cast<int>(eb.col_term.size()));
  }
  *out = std::move(eb);
  return true;
}

}  // namespace cadinterp::core
