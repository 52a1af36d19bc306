#include "core/basis.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cadinterp::core {

namespace {

void sort_unique(std::vector<int>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

}  // namespace

Basis::Basis(int K, Degree degree) : degree_(degree), tree_(K) {
  leaf_samples_.resize(1);
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
  sample_bsplines_.emplace_back();
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

std::vector<int> Basis::neighbourhood(int leaf) const {
  if (degree_ == Degree::Linear) return element_samples(leaf);
  std::vector<int> touching;
  tree_.leaves_touching(tree_.node(leaf).box, touching);
  std::vector<int> out;
  for (int m : touching) {
    const auto& s = element_samples(m);
    out.insert(out.end(), s.begin(), s.end());
  }
  sort_unique(out);
  return out;
}

int Basis::bspline_id(const BsplineKey& key) {
  const auto it = bspline_id_.find(key);
  if (it != bspline_id_.end()) return it->second;
  const int id = static_cast<int>(bsplines_.size());
  bsplines_.push_back(Bspline{key, {}, true});
  bspline_id_.emplace(key, id);
  ++live_bsplines_;
  return id;
}

void Basis::set_coeffs(int b, std::vector<Coefficient> coeffs) {
  Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
  for (const auto& [k, a] : bs.coeffs) {
    auto& list = sample_bsplines_[static_cast<std::size_t>(k)];
    list.erase(std::remove(list.begin(), list.end(), b), list.end());
  }
  coeffs.erase(
      std::remove_if(coeffs.begin(), coeffs.end(),
                     [](const Coefficient& c) { return std::abs(c.second) < kCoeffEpsilon; }),
      coeffs.end());
  std::sort(coeffs.begin(), coeffs.end());
  bs.coeffs = std::move(coeffs);
  for (const auto& [k, a] : bs.coeffs) sample_bsplines_[static_cast<std::size_t>(k)].push_back(b);
  if (bs.coeffs.empty()) kill_bspline(b);
}

void Basis::kill_bspline(int b) {
  Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
  if (!bs.alive) return;
  for (const auto& [k, a] : bs.coeffs) {
    auto& list = sample_bsplines_[static_cast<std::size_t>(k)];
    list.erase(std::remove(list.begin(), list.end(), b), list.end());
  }
  bs.coeffs.clear();
  bs.alive = false;
  bspline_id_.erase(bs.key);
  --live_bsplines_;
}

std::vector<int> Basis::bsplines_near(const std::vector<int>& samples) const {
  std::vector<int> out;
  for (int k : samples) {
    const auto& list = sample_bsplines_[static_cast<std::size_t>(k)];
    out.insert(out.end(), list.begin(), list.end());
  }
  sort_unique(out);
  return out;
}

bool Basis::overlaps_domain(const BsplineKey& key) const {
  IBox domain;
  for (int d = 0; d < dim(); ++d) domain.hi[d] = kUnit;
  return boxes_overlap(support_box(key, degree_, dim()), domain, dim());
}

bool Basis::sample_is_local(int k, const std::vector<int>& support_leaves) const {
  const IPoint& x = sample(k);
  const int K = dim();
  if (degree_ == Degree::Linear) {
    for (int n : support_leaves)
      if (!box_contains(tree_.node(n).box, x, K)) return false;
    return true;
  }
  // Cubic: k in Bbar(n) iff a leaf holding x_k touches n.
  std::vector<int> holders;
  tree_.leaves_containing(x, holders);
  for (int n : support_leaves) {
    const IBox& nb = tree_.node(n).box;
    bool near = false;
    for (int m : holders)
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
  const int K = dim();
  const IBox& box = tree_.node(leaf).box;
  ElementBasis eb;
  eb.leaf = leaf;
  // By locality every B-spline overlapping e has all its samples in the neighbourhood of e.
  std::vector<int> ids;
  for (int b : bsplines_near(neighbourhood(leaf)))
    if (boxes_overlap(support_box(bsplines_[static_cast<std::size_t>(b)].key, degree_, K), box, K))
      ids.push_back(b);
  for (int b : ids)
    for (const auto& [k, a] : bsplines_[static_cast<std::size_t>(b)].coeffs) eb.terms.push_back(k);
  sort_unique(eb.terms);
  eb.bsplines.reserve(ids.size());
  eb.coeff.assign(eb.terms.size() * ids.size(), 0.0);
  for (std::size_t j = 0; j < ids.size(); ++j) {
    const Bspline& bs = bsplines_[static_cast<std::size_t>(ids[j])];
    eb.bsplines.push_back(bs.key);
    for (const auto& [k, a] : bs.coeffs) {
      const auto row = std::lower_bound(eb.terms.begin(), eb.terms.end(), k) - eb.terms.begin();
      eb.coeff[static_cast<std::size_t>(row) * ids.size() + j] = a;
    }
  }
  return eb;
}

}  // namespace cadinterp::core
