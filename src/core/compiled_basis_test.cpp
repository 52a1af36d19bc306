// CompiledBasis::from_parts is the gate for arrays read from files: every corruption must be
// rejected with a message, or (for values it cannot tell from valid ones) evaluate safely.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "core/core_test_util.h"

namespace cadinterp::core {
namespace {

CompiledBasis::Parts valid_parts(Degree g) {
  std::mt19937_64 rng(9);
  Basis basis(2, g);
  testing::random_splits(basis, rng, 8, 4);
  return testing::compile_unit(basis).parts();
}

TEST(CompiledBasisParts, RoundTripsAndEvaluatesIdentically) {
  for (Degree g : {Degree::Linear, Degree::Cubic}) {
    std::mt19937_64 rng(1);
    Basis basis(3, g);
    testing::random_splits(basis, rng, 10, 4);
    const CompiledBasis a = testing::compile_unit(basis);
    const CompiledBasis b = CompiledBasis::from_parts(a.parts());
    EvalWorkspace wa = a.make_workspace(), wb = b.make_workspace();
    for (int i = 0; i < 200; ++i) {
      double x[3];
      for (double& v : x) v = std::uniform_real_distribution<double>(0, 1)(rng);
      BasisWeights pa, pb;
      ASSERT_TRUE(a.eval(x, wa, true, &pa));
      ASSERT_TRUE(b.eval(x, wb, true, &pb));
      ASSERT_EQ(pa.count, pb.count);
      for (int t = 0; t < pa.count; ++t) {
        EXPECT_EQ(pa.samples[t], pb.samples[t]);
        EXPECT_EQ(pa.psi[t], pb.psi[t]);
      }
    }
  }
}

TEST(CompiledBasisParts, RejectsEachKindOfCorruption) {
  using Mutation = void (*)(CompiledBasis::Parts&);
  const std::vector<std::pair<const char*, Mutation>> cases = {
      {"dimension", [](CompiledBasis::Parts& p) { p.K = 9; }},
      {"degree", [](CompiledBasis::Parts& p) { p.degree = static_cast<Degree>(2); }},
      {"range", [](CompiledBasis::Parts& p) { p.hi[0] = p.lo[0]; }},
      {"nan bound", [](CompiledBasis::Parts& p) { p.lo[1] = std::nan(""); }},
      {"sample", [](CompiledBasis::Parts& p) { p.sample_unit[3] = 1.5; }},
      {"child cycle", [](CompiledBasis::Parts& p) { p.node_child[0] = 0; }},
      {"child range", [](CompiledBasis::Parts& p) { p.node_child[1] = 1 << 30; }},
      {"split dir", [](CompiledBasis::Parts& p) { p.node_dir[0] = 7; }},
      {"leaf elem", [](CompiledBasis::Parts& p) { p.node_elem.back() = -5; }},
      {"term sample", [](CompiledBasis::Parts& p) { p.term_sample[0] = 1 << 20; }},
      {"col term", [](CompiledBasis::Parts& p) { p.col_term[0] = 1 << 20; }},
      {"offsets", [](CompiledBasis::Parts& p) { p.elem_bs_begin[1] = p.elem_bs_begin.back() + 1; }},
      {"coefficient",
       [](CompiledBasis::Parts& p) { p.col_value[2] = std::numeric_limits<double>::infinity(); }},
      {"width", [](CompiledBasis::Parts& p) { p.bs_inv_width[0] = 0.0; }},
      // Finite but not from a tree (found by fuzzing: NaN or inf gradients downstream).
      {"huge width", [](CompiledBasis::Parts& p) { p.bs_inv_width[0] = 2.7e154; }},
      {"odd width", [](CompiledBasis::Parts& p) { p.bs_inv_width[0] *= 1.5; }},
      {"off-grid centre", [](CompiledBasis::Parts& p) { p.bs_centre[0] += 1e-3; }},
      {"huge coefficient", [](CompiledBasis::Parts& p) { p.col_value[0] = 1.76e159; }},
      {"no partition of unity",
       [](CompiledBasis::Parts& p) {
         for (double& v : p.col_value) v *= 1.25;
       }},
      {"truncated", [](CompiledBasis::Parts& p) { p.col_value.pop_back(); }},
      {"box", [](CompiledBasis::Parts& p) { p.elem_box[0] = -0.25; }},
  };
  for (Degree g : {Degree::Linear, Degree::Cubic})
    for (const auto& [name, mutate] : cases) {
      CompiledBasis::Parts p = valid_parts(g);
      mutate(p);
      EXPECT_THROW(CompiledBasis::from_parts(std::move(p)), std::invalid_argument) << name;
    }
}

// Random single-entry corruptions: rejected, or safe to evaluate everywhere (run under ASan).
TEST(CompiledBasisParts, RandomCorruptionsAreRejectedOrSafe) {
  std::mt19937_64 rng(77);
  int rejected = 0, accepted = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    CompiledBasis::Parts p = valid_parts(trial % 2 ? Degree::Cubic : Degree::Linear);
    auto pick = [&](auto& v) -> auto& {
      return v[std::uniform_int_distribution<std::size_t>(0, v.size() - 1)(rng)];
    };
    const std::int64_t big[] = {-1, 0, 1, 2, 3, 1000, 1 << 30, -(1LL << 40)};
    const auto junk = big[std::uniform_int_distribution<int>(0, 7)(rng)];
    const CompiledBasis::Parts before = p;
    const int kind = trial % 8;
    switch (kind) {
      case 0:
        pick(p.node_child) = static_cast<std::int32_t>(junk);
        break;
      case 1:
        pick(p.node_elem) = static_cast<std::int32_t>(junk);
        break;
      case 2:
        pick(p.term_sample) = static_cast<std::int32_t>(junk);
        break;
      case 3:
        pick(p.col_term) = static_cast<std::int32_t>(junk);
        break;
      case 4:
        pick(p.elem_term_begin) = junk;
        break;
      case 5:
        pick(p.bs_col_begin) = junk;
        break;
      case 6:
        pick(p.node_dir) = static_cast<std::int8_t>(junk);
        break;
      default:
        pick(p.node_split) = static_cast<double>(junk) / 3.0;
        break;
    }
    // Tree corruptions (children, leaves, directions, splits) are always detectable.
    const bool tree_changed = (kind == 0 && p.node_child != before.node_child) ||
                              (kind == 1 && p.node_elem != before.node_elem) ||
                              (kind == 6 && p.node_dir != before.node_dir) ||
                              (kind == 7 && p.node_split != before.node_split);
    try {
      const CompiledBasis cb = CompiledBasis::from_parts(std::move(p));
      EXPECT_FALSE(tree_changed) << "accepted a corrupted tree (mutation kind " << kind << ")";
      ++accepted;
      EvalWorkspace ws = cb.make_workspace();
      for (int i = 0; i < 20; ++i) {
        double x[2] = {std::uniform_real_distribution<double>(0, 1)(rng),
                       std::uniform_real_distribution<double>(0, 1)(rng)};
        BasisWeights w;
        cb.eval(x, ws, true, &w);
      }
    } catch (const std::invalid_argument&) {
      ++rejected;
    }
  }
  std::printf("[ figures ] random corruptions: %d rejected, %d accepted and evaluated safely\n",
              rejected, accepted);
}

}  // namespace
}  // namespace cadinterp::core
