// Property tests of the adaptive basis over random split sequences (paper §4-5): 100 sequences
// for each K = 1..5 and each degree, 1,000 in all. Each sequence is checked for partition of
// unity, linear precision, locality, continuity across T-junctions, gradients against finite
// differences, agreement with a brute-force global sum, and the step-1 sample invariant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <string>

#include "core/core_test_util.h"
#include "core/faces.h"

namespace cadinterp::core {
namespace {

using testing::brute_element_samples;
using testing::brute_neighbourhood;
using testing::compile_unit;
using testing::global_psi;
using testing::random_point;
using testing::random_splits;

constexpr int kSequencesPerCase = 100;
constexpr int kPointsPerElement = 3;

struct Case {
  int K;
  Degree degree;
};

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  return "K" + std::to_string(info.param.K) +
         (info.param.degree == Degree::Linear ? "Linear" : "Cubic");
}

// Fewer splits in high K keep the suite fast; every sequence still produces T-junctions for
// K >= 2 (checked below).
int splits_for(int K) { return K == 1 ? 10 : K == 2 ? 14 : K == 3 ? 10 : K == 4 ? 7 : 5; }
constexpr int kMaxTestLevel = 6;

// A smooth non-polynomial test function on the unit box.
double smooth_f(const double* u, int K) {
  double s = 0.3;
  for (int d = 0; d < K; ++d) s += std::sin(2.0 + 3.0 * u[d] * (d + 1)) * (0.5 + 0.1 * d);
  return s * std::exp(0.5 * u[0]);
}

// Sum over terms of psi * value, and its gradient.
double blend(const BasisWeights& w, const std::vector<double>& value) {
  double s = 0.0;
  for (int t = 0; t < w.count; ++t) s += w.psi[t] * value[static_cast<std::size_t>(w.samples[t])];
  return s;
}
double blend_grad(const BasisWeights& w, int d, const std::vector<double>& value) {
  double s = 0.0;
  for (int t = 0; t < w.count; ++t)
    s += w.dpsi[d * w.count + t] * value[static_cast<std::size_t>(w.samples[t])];
  return s;
}

// Per-sample weights of an evaluation, as a map (absent = 0).
std::map<int, double> as_map(const BasisWeights& w, int d = -1) {
  std::map<int, double> m;
  for (int t = 0; t < w.count; ++t) m[w.samples[t]] = d < 0 ? w.psi[t] : w.dpsi[d * w.count + t];
  return m;
}

double max_diff(const std::map<int, double>& a, const std::map<int, double>& b) {
  double m = 0.0;
  std::set<int> keys;
  for (const auto& kv : a) keys.insert(kv.first);
  for (const auto& kv : b) keys.insert(kv.first);
  for (int k : keys) {
    const double x = a.count(k) ? a.at(k) : 0.0, y = b.count(k) ? b.at(k) : 0.0;
    m = std::max(m, std::abs(x - y));
  }
  return m;
}

class RandomTrees : public ::testing::TestWithParam<Case> {
 protected:
  // Largest jumps seen at T-junctions, reported once per case.
  double multilinear_jump_ = 0.0, ours_jump_ = 0.0;
  int t_junction_points_ = 0;
};

// Step 1 invariant (Definition 7): every corner of every common cuboid is a sample, and every
// sample is such a corner. Checked on single leaves and on all touching pairs and triples.
void check_samples(const Basis& basis) {
  const int K = basis.dim();
  const auto& leaves = basis.tree().leaves();
  auto corners_are_samples = [&](const IBox& r) {
    for (int mask = 0; mask < (1 << K); ++mask) {
      IPoint p{};
      for (int d = 0; d < K; ++d) p[d] = ((mask >> d) & 1) ? r.hi[d] : r.lo[d];
      ASSERT_GE(basis.find_sample(p), 0) << "missing sample at a common-cuboid corner";
    }
  };
  auto meet = [&](const IBox& a, const IBox& b) {
    IBox r;
    for (int d = 0; d < K; ++d) {
      r.lo[d] = std::max(a.lo[d], b.lo[d]);
      r.hi[d] = std::min(a.hi[d], b.hi[d]);
    }
    return r;
  };
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    const IBox& a = basis.tree().node(leaves[i]).box;
    corners_are_samples(a);
    for (std::size_t j = i + 1; j < leaves.size(); ++j) {
      const IBox& b = basis.tree().node(leaves[j]).box;
      if (!boxes_touch(a, b, K)) continue;
      const IBox ab = meet(a, b);
      corners_are_samples(ab);
      for (std::size_t l = j + 1; l < leaves.size(); ++l) {
        const IBox& c = basis.tree().node(leaves[l]).box;
        if (boxes_touch(ab, c, K)) corners_are_samples(meet(ab, c));
      }
    }
  }
  // No spurious samples: each is a corner of the intersection of the leaves holding it.
  for (int k = 0; k < basis.sample_count(); ++k) {
    const IPoint& p = basis.sample(k);
    IBox r;
    bool first = true;
    for (int leaf : leaves) {
      const IBox& b = basis.tree().node(leaf).box;
      if (!box_contains(b, p, K)) continue;
      r = first ? b : meet(r, b);
      first = false;
    }
    ASSERT_FALSE(first) << "sample outside every leaf";
    for (int d = 0; d < K; ++d)
      ASSERT_TRUE(p[d] == r.lo[d] || p[d] == r.hi[d]) << "spurious sample";
  }
  // Deduplicated.
  std::set<IPoint> unique;
  for (int k = 0; k < basis.sample_count(); ++k) unique.insert(basis.sample(k));
  ASSERT_EQ(static_cast<int>(unique.size()), basis.sample_count());
  // B(e) as maintained equals B(e) from raw geometry.
  for (int leaf : leaves)
    ASSERT_EQ(basis.element_samples(leaf), brute_element_samples(basis, leaf));
}

// Remark 1 with neighbourhoods computed from raw geometry: alpha_k^b != 0 only if k is in B(e)
// (Bbar(e) for cubic) of every leaf e whose interior meets the support of phi_b.
void check_locality(const Basis& basis) {
  const int K = basis.dim();
  std::map<int, std::vector<bool>> nbh;
  for (int leaf : basis.tree().leaves()) nbh[leaf] = brute_neighbourhood(basis, leaf);
  basis.for_each_bspline([&](const BsplineKey& key, const std::vector<Coefficient>& coeffs) {
    const IBox sup = support_box(key, basis.degree(), K);
    for (int leaf : basis.tree().leaves()) {
      if (!boxes_overlap(sup, basis.tree().node(leaf).box, K)) continue;
      for (const auto& [k, a] : coeffs)
        ASSERT_TRUE(nbh[leaf][static_cast<std::size_t>(k)])
            << "locality: sample " << k << " (alpha " << a << ") outside the neighbourhood of leaf "
            << leaf;
    }
  });
}

TEST_P(RandomTrees, InterpolationProperties) {
  const int K = GetParam().K;
  const Degree g = GetParam().degree;
  std::mt19937_64 rng(1234u + static_cast<unsigned>(K) * 17u + static_cast<unsigned>(g));
  int sequences_with_tjunctions = 0;
  std::uniform_real_distribution<double> coef(-2.0, 2.0);

  for (int seq = 0; seq < kSequencesPerCase; ++seq) {
    SCOPED_TRACE("sequence " + std::to_string(seq));
    Basis basis(K, g);
    random_splits(basis, rng, splits_for(K), kMaxTestLevel);
    const CompiledBasis cb = compile_unit(basis);
    EvalWorkspace ws = cb.make_workspace();
    BasisWeights w;

    check_samples(basis);
    check_locality(basis);
    if (HasFatalFailure()) return;

    // Values of a random linear function and of a smooth function at every sample.
    std::vector<double> a(static_cast<std::size_t>(K));
    for (double& ai : a) ai = coef(rng);
    const double a0 = coef(rng);
    std::vector<double> lin(static_cast<std::size_t>(basis.sample_count())), smooth(lin.size());
    for (int k = 0; k < basis.sample_count(); ++k) {
      double u[kMaxDim];
      cb.sample_position(k, u);
      double s = a0;
      for (int d = 0; d < K; ++d) s += a[static_cast<std::size_t>(d)] * u[d];
      lin[static_cast<std::size_t>(k)] = s;
      smooth[static_cast<std::size_t>(k)] = smooth_f(u, K);
    }

    for (int e = 0; e < cb.element_count(); ++e) {
      const int leaf = basis.tree().leaves()[static_cast<std::size_t>(e)];
      const IBox& box = basis.tree().node(leaf).box;
      for (int p = 0; p < kPointsPerElement; ++p) {
        const std::vector<double> u = random_point(box, K, rng);
        ASSERT_EQ(cb.locate(u.data()), e);
        cb.eval_element(e, u.data(), ws, true, &w);

        // Partition of unity (and its derivative).
        double sum = 0.0;
        for (int t = 0; t < w.count; ++t) sum += w.psi[t];
        ASSERT_LE(std::abs(sum - 1.0), 1e-12) << "partition of unity";
        for (int d = 0; d < K; ++d) {
          double gs = 0.0;
          for (int t = 0; t < w.count; ++t) gs += w.dpsi[d * w.count + t];
          ASSERT_LE(std::abs(gs), 1e-9) << "gradient of the partition of unity";
        }

        // Linear precision: value and gradient.
        double exact = a0;
        for (int d = 0; d < K; ++d) exact += a[static_cast<std::size_t>(d)] * u[d];
        ASSERT_LE(std::abs(blend(w, lin) - exact), 1e-10) << "linear precision";
        for (int d = 0; d < K; ++d)
          ASSERT_LE(std::abs(blend_grad(w, d, lin) - a[static_cast<std::size_t>(d)]), 1e-8)
              << "linear precision of the gradient";

        // Locality, functional form: the global sum over all B-splines is nonzero only on the
        // element's neighbourhood and equals the element-local evaluation.
        const std::vector<double> gpsi = global_psi(basis, u.data());
        const std::vector<bool> nbh = brute_neighbourhood(basis, leaf);
        const std::map<int, double> local = as_map(w);
        for (int k = 0; k < basis.sample_count(); ++k) {
          const double gk = gpsi[static_cast<std::size_t>(k)];
          if (std::abs(gk) > 1e-15) {
            ASSERT_TRUE(nbh[static_cast<std::size_t>(k)]) << "psi_" << k << " nonzero off B(e)";
          }
          const double lk = local.count(k) ? local.at(k) : 0.0;
          ASSERT_LE(std::abs(gk - lk), 1e-12) << "element-local psi differs from the global sum";
        }

        // Gradient against central differences. Linear B-splines have kinks at their knots:
        // only use stencils that stay inside one polynomial piece of every B-spline.
        const ElementBasis eb = basis.element_basis(leaf);
        const double h = 1e-6 * to_unit(width_at(kMaxTestLevel));
        for (int d = 0; d < K; ++d) {
          if (g == Degree::Linear) {
            bool smooth_here = true;
            for (const BsplineKey& key : eb.bsplines) {
              const double wk = to_unit(width_at(key.level[d]));
              const double t = (u[static_cast<std::size_t>(d)] - to_unit(key.centre[d])) / wk;
              if (std::floor(t - 2 * h / wk) != std::floor(t + 2 * h / wk)) smooth_here = false;
            }
            if (!smooth_here) continue;
          }
          std::vector<double> up = u, dn = u;
          up[static_cast<std::size_t>(d)] += h;
          dn[static_cast<std::size_t>(d)] -= h;
          const std::map<int, double> grad = as_map(w, d);
          BasisWeights wu, wd;
          EvalWorkspace ws2 = cb.make_workspace();
          cb.eval_element(e, up.data(), ws, false, &wu);
          const std::map<int, double> pu = as_map(wu);
          cb.eval_element(e, dn.data(), ws2, false, &wd);
          const std::map<int, double> pd = as_map(wd);
          for (const auto& [k, gk] : grad) {
            const double fd = (pu.at(k) - pd.at(k)) / (2 * h);
            ASSERT_NEAR(gk, fd, 1e-6 * (1.0 + std::abs(gk))) << "d psi_" << k << "/dx_" << d;
          }
          cb.eval_element(e, u.data(), ws, true, &w);  // restore w for the next direction
        }
      }
    }

    // Continuity across faces between leaves of different levels. Values (and cubic gradients)
    // from the two sides' element data must agree; per-element multilinear interpolation of the
    // same samples must not (it is the baseline that jumps at T-junctions).
    bool has_tjunction = false;
    EvalWorkspace ws_lo = cb.make_workspace(), ws_hi = cb.make_workspace();
    std::map<int, int> elem_of_leaf;
    for (int e = 0; e < cb.element_count(); ++e)
      elem_of_leaf[basis.tree().leaves()[static_cast<std::size_t>(e)]] = e;
    for (const SharedFace& f : shared_faces(basis.tree())) {
      if (!f.t_junction) continue;
      has_tjunction = true;
      for (int p = 0; p < kPointsPerElement; ++p) {
        const std::vector<double> u = random_point(f.box, K, rng);
        BasisWeights wl, wh;
        cb.eval_element(elem_of_leaf[f.lower], u.data(), ws_lo, true, &wl);
        cb.eval_element(elem_of_leaf[f.upper], u.data(), ws_hi, true, &wh);
        ASSERT_LE(max_diff(as_map(wl), as_map(wh)), 1e-10) << "psi jumps across a T-junction";
        const double jump = std::abs(blend(wl, smooth) - blend(wh, smooth));
        ASSERT_LE(jump, 1e-10) << "interpolant jumps across a T-junction";
        if (g == Degree::Cubic) {
          for (int d = 0; d < K; ++d)
            ASSERT_LE(max_diff(as_map(wl, d), as_map(wh, d)), 1e-8)
                << "cubic gradient jumps across a T-junction in direction " << d;
        }
        auto value = [&](int k) { return smooth[static_cast<std::size_t>(k)]; };
        const double ml = multilinear_in_element(basis, f.lower, u.data(), value);
        const double mh = multilinear_in_element(basis, f.upper, u.data(), value);
        multilinear_jump_ = std::max(multilinear_jump_, std::abs(ml - mh));
        ours_jump_ = std::max(ours_jump_, jump);
        ++t_junction_points_;
      }
    }
    sequences_with_tjunctions += has_tjunction ? 1 : 0;
  }

  if (K >= 2) {
    // The baseline must visibly jump, or the continuity check above proves nothing.
    EXPECT_GT(sequences_with_tjunctions, kSequencesPerCase / 2);
    EXPECT_GT(multilinear_jump_, 1e-3) << "per-element multilinear shows no T-junction jump";
    std::printf(
        "[ figures ] K=%d %s: %d T-junction points; max jump per-element multilinear %.3e, "
        "ours %.3e\n",
        K, g == Degree::Linear ? "linear" : "cubic", t_junction_points_, multilinear_jump_,
        ours_jump_);
    RecordProperty("multilinear_jump", std::to_string(multilinear_jump_));
    RecordProperty("ours_jump", std::to_string(ours_jump_));
  }
}

INSTANTIATE_TEST_SUITE_P(Core, RandomTrees,
                         ::testing::Values(Case{1, Degree::Linear}, Case{2, Degree::Linear},
                                           Case{3, Degree::Linear}, Case{4, Degree::Linear},
                                           Case{5, Degree::Linear}, Case{1, Degree::Cubic},
                                           Case{2, Degree::Cubic}, Case{3, Degree::Cubic},
                                           Case{4, Degree::Cubic}, Case{5, Degree::Cubic}),
                         case_name);

// A uniform tree with the linear basis is plain multilinear interpolation on the grid.
TEST(UniformTree, LinearBasisIsMultilinearInterpolation) {
  for (int K = 1; K <= 4; ++K) {
    Basis basis(K, Degree::Linear);
    std::vector<int> levels(static_cast<std::size_t>(K));
    for (int d = 0; d < K; ++d) levels[static_cast<std::size_t>(d)] = 1 + (d % 3);
    for (int d = 0; d < K; ++d)
      for (int l = 0; l < levels[static_cast<std::size_t>(d)]; ++l) {
        const std::vector<int> leaves = basis.tree().leaves();
        for (int leaf : leaves) basis.refine(leaf, d);
      }
    const CompiledBasis cb = compile_unit(basis);
    std::vector<double> v(static_cast<std::size_t>(basis.sample_count()));
    for (int k = 0; k < basis.sample_count(); ++k) {
      double u[kMaxDim];
      cb.sample_position(k, u);
      v[static_cast<std::size_t>(k)] = smooth_f(u, K);
    }
    std::mt19937_64 rng(7);
    EvalWorkspace ws = cb.make_workspace();
    for (int i = 0; i < 500; ++i) {
      IBox unit;
      for (int d = 0; d < K; ++d) unit.hi[d] = kUnit;
      const std::vector<double> u = random_point(unit, K, rng);
      BasisWeights w;
      ASSERT_TRUE(cb.eval(u.data(), ws, false, &w));
      ASSERT_EQ(w.count, 1 << K) << "multilinear uses exactly the element's corners";
      const int leaf = basis.tree().leaves()[static_cast<std::size_t>(w.element)];
      const double ml = multilinear_in_element(
          basis, leaf, u.data(), [&](int k) { return v[static_cast<std::size_t>(k)]; });
      ASSERT_NEAR(blend(w, v), ml, 1e-12);
    }
  }
}

// Points on faces and corners go to one element deterministically; outside points are refused.
TEST(Locate, FacesAreDeterministicAndOutsideIsRejected) {
  Basis basis(2, Degree::Linear);
  basis.refine(0, 0);
  const CompiledBasis cb = compile_unit(basis);
  const double on_face[2] = {0.5, 0.25};
  const double upper_corner[2] = {1.0, 1.0};
  const double lower_corner[2] = {0.0, 0.0};
  EXPECT_EQ(cb.locate(on_face), 1) << "a face point belongs to the upper element";
  EXPECT_EQ(cb.locate(upper_corner), 1);
  EXPECT_EQ(cb.locate(lower_corner), 0);
  const double outside[2] = {1.0 + 1e-12, 0.5};
  const double nan[2] = {std::nan(""), 0.5};
  EXPECT_EQ(cb.locate(outside), -1);
  EXPECT_EQ(cb.locate(nan), -1);
  EvalWorkspace ws = cb.make_workspace();
  BasisWeights w;
  w.element = 77;
  EXPECT_FALSE(cb.eval(outside, ws, false, &w));
  EXPECT_EQ(w.element, 77) << "a failed eval leaves its output untouched";
}

// The paper's 1-D example (Figure 9): after one split the linear basis is the hat basis on the
// new grid; the midpoint sample's basis function is the new fine hat.
TEST(PaperExample, OneDimensionalSplitIsElementRefinement) {
  Basis basis(1, Degree::Linear);
  basis.refine(0, 0);
  ASSERT_EQ(basis.sample_count(), 3);
  const CompiledBasis cb = compile_unit(basis);
  EvalWorkspace ws = cb.make_workspace();
  for (double x : {0.1, 0.25, 0.4, 0.6, 0.9}) {
    BasisWeights w;
    ASSERT_TRUE(cb.eval(&x, ws, false, &w));
    const std::map<int, double> m = as_map(w);
    const double mid_weight = 1.0 - std::abs(x - 0.5) / 0.5;
    EXPECT_NEAR(m.at(2), mid_weight, 1e-15);
    EXPECT_EQ(w.count, 2) << "each element depends only on its two end samples";
  }
}

// The cubic basis near the domain boundary: B-splines centred outside the domain have no
// sample; the extrapolation weights must still give a partition of unity and linear precision
// on the boundary itself.
TEST(CubicBoundary, PartitionOfUnityAndLinearPrecisionOnTheBoundary) {
  Basis basis(2, Degree::Cubic);
  basis.refine(0, 0);
  basis.refine(basis.tree().leaves()[0], 1);
  basis.refine(basis.tree().leaves()[0], 0);
  const CompiledBasis cb = compile_unit(basis);
  EvalWorkspace ws = cb.make_workspace();
  std::vector<double> lin(static_cast<std::size_t>(basis.sample_count()));
  for (int k = 0; k < basis.sample_count(); ++k) {
    double u[2];
    cb.sample_position(k, u);
    lin[static_cast<std::size_t>(k)] = 0.5 + 2.0 * u[0] - 3.0 * u[1];
  }
  for (double s : {0.0, 0.125, 0.3, 0.5, 0.77, 1.0}) {
    for (const auto& u :
         std::vector<std::array<double, 2>>{{0.0, s}, {1.0, s}, {s, 0.0}, {s, 1.0}}) {
      BasisWeights w;
      ASSERT_TRUE(cb.eval(u.data(), ws, true, &w));
      double sum = 0.0;
      for (int t = 0; t < w.count; ++t) sum += w.psi[t];
      EXPECT_NEAR(sum, 1.0, 1e-12);
      EXPECT_NEAR(blend(w, lin), 0.5 + 2.0 * u[0] - 3.0 * u[1], 1e-12);
      EXPECT_NEAR(blend_grad(w, 0, lin), 2.0, 1e-9);
      EXPECT_NEAR(blend_grad(w, 1, lin), -3.0, 1e-9);
    }
  }
}

// The per-leaf index finds the B-splines over a refined element (Basis::set_reference_search);
// scanning every B-spline near it is the unindexed algorithm. Both must build the same basis,
// bit for bit: same samples, same B-splines in the same order, same coefficients.
TEST(IndexedRefinement, SameBasisAsTheReferenceScan) {
  for (int K = 1; K <= 4; ++K)
    for (Degree g : {Degree::Linear, Degree::Cubic})
      for (int seed = 0; seed < 2; ++seed) {
        SCOPED_TRACE("K=" + std::to_string(K) + " cubic=" + std::to_string(g == Degree::Cubic) +
                     " seed=" + std::to_string(seed));
        Basis indexed(K, g), reference(K, g);
        reference.set_reference_search(true);
        std::mt19937_64 rng_a(1000 + 10 * K + seed), rng_b(1000 + 10 * K + seed);
        random_splits(indexed, rng_a, 6 * K, 5);
        random_splits(reference, rng_b, 6 * K, 5);
        ASSERT_EQ(indexed.tree().node_count(), reference.tree().node_count());
        ASSERT_EQ(indexed.sample_count(), reference.sample_count());
        for (int k = 0; k < indexed.sample_count(); ++k)
          ASSERT_EQ(indexed.sample(k), reference.sample(k));
        std::vector<std::pair<BsplineKey, std::vector<Coefficient>>> a, b;
        indexed.for_each_bspline([&](const BsplineKey& key, const std::vector<Coefficient>& c) {
          a.emplace_back(key, c);
        });
        reference.for_each_bspline([&](const BsplineKey& key, const std::vector<Coefficient>& c) {
          b.emplace_back(key, c);
        });
        ASSERT_EQ(a.size(), b.size());
        EXPECT_GT(a.size(), std::size_t(1) << K);  // the splits refined the level-0 basis
        for (std::size_t i = 0; i < a.size(); ++i) {
          ASSERT_TRUE(a[i].first == b[i].first) << "B-spline " << i;
          ASSERT_EQ(a[i].second, b[i].second) << "B-spline " << i;  // exact doubles
        }
      }
}

}  // namespace
}  // namespace cadinterp::core
