// Algorithm 1 (paper §5.2): refine an element along one direction while keeping the basis
// local, a partition of unity and linearly precise. Cubic extension of §5.3.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/basis.h"

namespace cadinterp::core {

namespace {

// Adds w * src into dst; both sorted by sample id, result sorted.
void axpy(std::vector<Coefficient>& dst, double w, const std::vector<Coefficient>& src) {
  std::vector<Coefficient> out;
  out.reserve(dst.size() + src.size());
  std::size_t i = 0, j = 0;
  while (i < dst.size() || j < src.size()) {
    if (j == src.size() || (i < dst.size() && dst[i].first < src[j].first)) {
      out.push_back(dst[i++]);
    } else if (i == dst.size() || src[j].first < dst[i].first) {
      out.emplace_back(src[j].first, w * src[j].second);
      ++j;
    } else {
      out.emplace_back(dst[i].first, dst[i].second + w * src[j].second);
      ++i;
      ++j;
    }
  }
  dst = std::move(out);
}

}  // namespace

std::vector<int> Basis::refine(int leaf, int dir) {
  const KdTree::Node parent = tree_.node(leaf);
  const auto kids = tree_.split(leaf, dir);  // validates leaf, dir and level
  ++refines_;
  const Coord mid = tree_.node(kids[1]).box.lo[dir];
  const int K = dim();

  // Step 1 (element refinement): the children inherit the parent's samples that lie on them,
  // then samples are added at the corners of every new common cuboid.
  leaf_samples_.resize(static_cast<std::size_t>(tree_.node_count()));
  leaf_bsplines_.resize(static_cast<std::size_t>(tree_.node_count()));
  for (int kid : kids) {
    const IBox& kb = tree_.node(kid).box;
    auto& mine = leaf_samples_[static_cast<std::size_t>(kid)];
    for (int k : leaf_samples_[static_cast<std::size_t>(leaf)])
      if (box_contains(kb, sample(k), K)) mine.push_back(k);
    auto& overlapping = leaf_bsplines_[static_cast<std::size_t>(kid)];
    for (int b : leaf_bsplines_[static_cast<std::size_t>(leaf)])
      if (boxes_overlap(bsplines_[static_cast<std::size_t>(b)].support, kb, K))
        overlapping.push_back(b);
  }
  std::vector<int>().swap(leaf_samples_[static_cast<std::size_t>(leaf)]);
  std::vector<int>().swap(leaf_bsplines_[static_cast<std::size_t>(leaf)]);
  std::vector<int> added = add_split_samples(parent.box, dir, mid);

  // Only B-splines overlapping the parent, or (cubic) a leaf touching it, can need refinement or
  // lose locality: elsewhere neighbourhoods only gained samples.
  std::vector<int> touching;
  tree_.leaves_touching(parent.box, touching);

  // Step 2 (basis refinement, Eq. 8). The B-splines overlapping the element are first brought
  // to one level per direction (the finest among them), then refined along `dir` to the
  // children's level. Read literally, step 2 refines only along `dir`; B-splines of different
  // levels in another direction then have children that never merge, and a child's
  // y = sum alpha x / sum alpha can leave the affine hull of its local samples, so that Eq. 10
  // cannot keep linear precision (3 splits suffice in 2-D). With one level over e, the
  // B-splines restricted to e are linearly independent, so partition of unity and linear
  // precision force sum_k alpha_k^b = 1 and y_b = centre of phi_b for each of them; and as no
  // leaf is finer than a B-spline overlapping it, the centre lies on every leaf meeting the
  // support: it is a local point, and Eq. 10 always succeeds.
  // Cubic: Bbar of each leaf touching the element can lose samples, so B-splines overlapping
  // those leaves may break locality too; they are brought to one level per leaf likewise.
  std::vector<int> near_bsplines = bsplines_overlapping(touching);
  uniformize(parent.box, {kids[0], kids[1]}, dir, parent.level[dir] + 1, near_bsplines);
  if (degree_ == Degree::Cubic)
    for (int n : touching)
      if (n != kids[0] && n != kids[1]) uniformize(tree_.node(n).box, {n}, -1, 0, near_bsplines);

  // Step 3 (combination, Eq. 10).
  std::vector<int> candidates;
  for (int b : near_bsplines) {
    if (!bsplines_[static_cast<std::size_t>(b)].alive) continue;
    const IBox& sup = bsplines_[static_cast<std::size_t>(b)].support;
    const bool hits = degree_ == Degree::Linear
                          ? boxes_overlap(sup, parent.box, K)
                          : std::any_of(touching.begin(), touching.end(), [&](int n) {
                              return boxes_overlap(sup, tree_.node(n).box, K);
                            });
    if (hits) candidates.push_back(b);
  }
  // The leaves whose neighbourhood (B(e) linear, Bbar(e) cubic) can have lost samples: the
  // children, and for cubic the leaves touching only one of them (a leaf touching both still
  // sees every sample of the parent).
  std::vector<int> shrunk{kids[0], kids[1]};
  if (degree_ == Degree::Cubic)
    for (int n : touching) {
      const IBox& nb = tree_.node(n).box;
      if (n != kids[0] && n != kids[1] &&
          !(boxes_touch(nb, tree_.node(kids[0]).box, K) &&
            boxes_touch(nb, tree_.node(kids[1]).box, K)))
        shrunk.push_back(n);
    }
  enforce_locality(candidates, shrunk);
  return added;
}

void Basis::uniformize(const IBox& box, const std::vector<int>& box_leaves, int dir, int min_level,
                       std::vector<int>& near) {
  // `near` holds every B-spline that can overlap `box` (increasing ids); B-splines created here
  // have the largest ids and are appended, so it stays complete and sorted for the next call.
  // The live B-splines overlapping `box` are those the index lists on the leaves tiling it
  // (`box_leaves`), in the same increasing order as the scan of `near` finds them: a touching
  // leaf sees a handful of the B-splines near a split, and scanning all of them for every
  // touching leaf grew with the square of the neighbourhood (cubic, §5.3).
  const int K = dim();
  std::array<int, kMaxDim> target{};
  std::vector<int> over;
  if (reference_search_) {
    for (int b : near) {
      const Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
      if (bs.alive && boxes_overlap(bs.support, box, K)) over.push_back(b);
    }
  } else {
    over = bsplines_overlapping(box_leaves);
  }
  for (int b : over)
    for (int d = 0; d < K; ++d)
      target[d] = std::max(target[d], int(bsplines_[static_cast<std::size_t>(b)].key.level[d]));
  if (dir >= 0) target[dir] = std::max(target[dir], min_level);
  const int first_new = static_cast<int>(bsplines_.size());
  refine_bsplines(box, target, over);
  for (int b = first_new; b < static_cast<int>(bsplines_.size()); ++b)
    if (bsplines_[static_cast<std::size_t>(b)].alive) near.push_back(b);
}

std::vector<int> Basis::add_split_samples(const IBox& parent, int dir, Coord mid) {
  // New samples lie on the split plane inside the parent (off the plane, the set of leaves
  // holding a point and their faces are unchanged). In each other direction their coordinate is
  // a face of a leaf holding them, i.e. of a leaf touching the parent.
  const int K = dim();
  std::vector<int> touching;
  tree_.leaves_touching(parent, touching);
  std::array<std::vector<Coord>, kMaxDim> values;
  for (int d = 0; d < K; ++d) {
    auto& v = values[static_cast<std::size_t>(d)];
    if (d == dir) {
      v.push_back(mid);
      continue;
    }
    for (int n : touching) {
      const IBox& b = tree_.node(n).box;
      for (Coord c : {b.lo[d], b.hi[d]})
        if (c >= parent.lo[d] && c <= parent.hi[d]) v.push_back(c);
    }
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }

  std::vector<int> added;
  std::vector<int> scratch;
  std::array<std::size_t, kMaxDim> idx{};
  for (;;) {
    IPoint p{};
    for (int d = 0; d < K; ++d) p[d] = values[static_cast<std::size_t>(d)][idx[d]];
    if (find_sample(p) < 0 && is_sample_point(p, scratch)) added.push_back(add_sample(p));
    int d = 0;
    while (d < K && ++idx[d] == values[static_cast<std::size_t>(d)].size()) idx[d++] = 0;
    if (d == K) break;
  }
  return added;
}

void Basis::refine_bsplines(const IBox& parent, const std::array<int, kMaxDim>& target,
                            const std::vector<int>& candidates) {
  const int K = dim();
  const RefinementMask mask = refinement_mask(degree_);
  // The first direction in which B-spline b overlapping the parent is coarser than the target.
  auto coarse_dir = [&](int b) {
    const Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
    if (!bs.alive || !boxes_overlap(bs.support, parent, K)) return -1;
    for (int d = 0; d < K; ++d)
      if (bs.key.level[d] < target[d]) return d;
    return -1;
  };
  std::vector<int> work(candidates.rbegin(), candidates.rend());
  while (!work.empty()) {
    const int b = work.back();
    work.pop_back();
    const int dir = coarse_dir(b);
    if (dir < 0) continue;
    const Bspline parent_bs = bsplines_[static_cast<std::size_t>(b)];
    kill_bspline(b);
    const Coord half = width_at(parent_bs.key.level[dir] + 1);
    for (int t = 0; t < mask.count; ++t) {
      BsplineKey child = parent_bs.key;
      ++child.level[dir];
      child.centre[dir] += static_cast<Coord>(mask.first_offset + t) * half;
      if (!overlaps_domain(child)) continue;  // zero on the domain
      const int c = bspline_id(child);
      std::vector<Coefficient> merged = bsplines_[static_cast<std::size_t>(c)].coeffs;
      axpy(merged, mask.weight[static_cast<std::size_t>(t)], parent_bs.coeffs);  // Eq. 8
      set_coeffs(c, std::move(merged));
      if (coarse_dir(c) >= 0) work.push_back(c);
    }
  }
}

void Basis::enforce_locality(const std::vector<int>& candidates, const std::vector<int>& shrunk) {
  // Every B-spline was local before this refinement. One whose coefficients step 2 left alone
  // can only lose locality on the leaves whose neighbourhood lost samples (`shrunk`): the other
  // leaves' neighbourhoods are unchanged or gained samples. So only those leaves are tested for
  // it, which spares most (coefficient, leaf) tests on deep cubic trees; B-splines step 2
  // created or changed are tested on their whole support.
  std::vector<int> support_leaves;
  HolderCache holders;
  const int K = dim();
  for (int b : candidates) {
    const Bspline& bs = bsplines_[static_cast<std::size_t>(b)];
    if (!bs.alive) continue;
    support_leaves.clear();
    if (bs.changed_in == refines_ || reference_search_) {
      tree_.leaves_overlapping(bs.support, support_leaves);
    } else {
      for (int n : shrunk)
        if (boxes_overlap(bs.support, tree_.node(n).box, K)) support_leaves.push_back(n);
      if (support_leaves.empty()) continue;
    }
    const bool local = std::all_of(bs.coeffs.begin(), bs.coeffs.end(), [&](const Coefficient& c) {
      return sample_is_local(c.first, support_leaves, holders);
    });
    if (local) continue;
    std::vector<Coefficient> moved = reallocate(bs);
    support_leaves.clear();  // the target must be local on the whole support
    tree_.leaves_overlapping(bs.support, support_leaves);
    for (const auto& [k, a] : moved)
      if (!sample_is_local(k, support_leaves, holders)) {
        throw std::logic_error("Basis::refine: reallocation target is not a local sample");
      }
    set_coeffs(b, std::move(moved));
  }
}

std::vector<Coefficient> Basis::reallocate(const Bspline& b) const {
  // Eq. 10 with y = sum_k alpha_k x_k / sum_k alpha_k (the linear-precision choice of §5.2).
  const int K = dim();
  double sum = 0.0;
  std::array<double, kMaxDim> y{};
  for (const auto& [k, a] : b.coeffs) {
    sum += a;
    for (int d = 0; d < K; ++d) y[d] += a * static_cast<double>(sample(k)[d]);
  }
  if (!(sum > 0.0)) throw std::logic_error("Basis::refine: B-spline weight sum is not positive");
  std::array<double, kMaxDim> clamped{};
  for (int d = 0; d < K; ++d) {
    y[d] /= sum;
    const double r = std::round(y[d]);
    if (std::abs(y[d] - r) <= kSnap) y[d] = r;
    clamped[d] = std::clamp(y[d], 0.0, static_cast<double>(kUnit));
  }

  // R = intersection of the leaves holding (clamped) y: a common cuboid, so its corners are
  // samples (step 1). Where y was clamped, R has positive width and y is extrapolated.
  std::vector<int> holders;
  tree_.leaves_containing(clamped.data(), holders);
  if (holders.empty()) throw std::logic_error("Basis::refine: reallocation point outside the tree");
  IBox R = tree_.node(holders[0]).box;
  for (int n : holders)
    for (int d = 0; d < K; ++d) {
      R.lo[d] = std::max(R.lo[d], tree_.node(n).box.lo[d]);
      R.hi[d] = std::min(R.hi[d], tree_.node(n).box.hi[d]);
    }

  // Multilinear weights beta_r of y in the corners of R, per direction.
  std::array<Coord, kMaxDim * 2> corner{};
  std::array<double, kMaxDim * 2> weight{};
  std::array<int, kMaxDim> count{};
  for (int d = 0; d < K; ++d) {
    const auto i = static_cast<std::size_t>(2 * d);
    if (R.lo[d] == R.hi[d]) {
      corner[i] = R.lo[d];
      weight[i] = 1.0;
      count[d] = 1;
      continue;
    }
    const double lo = static_cast<double>(R.lo[d]), hi = static_cast<double>(R.hi[d]);
    corner[i] = R.lo[d];
    corner[i + 1] = R.hi[d];
    weight[i] = (hi - y[d]) / (hi - lo);
    weight[i + 1] = (y[d] - lo) / (hi - lo);
    count[d] = 2;
  }
  std::vector<Coefficient> out;
  std::array<int, kMaxDim> idx{};
  for (;;) {
    IPoint p{};
    double w = sum;
    for (int d = 0; d < K; ++d) {
      const auto i = static_cast<std::size_t>(2 * d + idx[d]);
      p[d] = corner[i];
      w *= weight[i];
    }
    if (w != 0.0) {
      const int k = find_sample(p);
      if (k < 0) throw std::logic_error("Basis::refine: common cuboid corner is not a sample");
      out.emplace_back(k, w);
    }
    int d = 0;
    while (d < K && ++idx[d] == count[d]) idx[d++] = 0;
    if (d == K) break;
  }
  return out;
}

}  // namespace cadinterp::core
