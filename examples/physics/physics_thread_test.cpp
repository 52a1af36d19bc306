// solve() is reentrant: concurrent calls (the builder runs host samples on several threads)
// give bit-identical results to serial ones. Labelled `concurrency` so it runs under TSan.
#include <gtest/gtest.h>

#include <thread>
#include <vector>

#include "physics.h"
#include "physics_test_meshes.h"

namespace {

using namespace cadinterp::physics;
using namespace cadinterp::physics::testing;

Problem problem(int variant) {
  Problem p;
  p.mesh = box_mesh(4, 1, 1, 8 + variant, 2, 2);
  p.thermal = variant % 2 == 1;
  p.order = variant % 3 == 2 ? 2 : 1;
  // The Eigen-based solvers only: Debian's CHOLMOD runs OpenMP threads inside a factorization
  // and TSan, not seeing the uninstrumented libgomp's synchronization, reports its memsets
  // as races. solve() itself shares nothing between calls either way.
  p.solver = variant % 2 == 0 ? LinearSolver::conjugate_gradient
                              : LinearSolver::conjugate_gradient_two_level;
  p.fixed.push_back({{kXLow}, {true, true, true}});
  p.forces.push_back({{kXHigh}, {0, 1.0 + variant, -2.0}});
  if (p.thermal) {
    p.temperatures.push_back({{kXLow}, 20.0});
    p.convections.push_back({{kYHigh}, 0.1, 80.0});
  }
  return p;
}

TEST(PhysicsThreads, ConcurrentSolvesMatchSerialOnes) {
  constexpr int kThreads = 4;
  std::vector<Solution> serial, parallel(kThreads);
  for (int i = 0; i < kThreads; ++i) serial.push_back(solve(problem(i)));
  std::vector<std::thread> threads;
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([i, &parallel] { parallel[i] = solve(problem(i)); });
  }
  for (std::thread& t : threads) t.join();
  for (int i = 0; i < kThreads; ++i) {
    EXPECT_EQ(parallel[i].displacement, serial[i].displacement) << i;
    EXPECT_EQ(parallel[i].von_mises, serial[i].von_mises) << i;
    EXPECT_EQ(parallel[i].temperature, serial[i].temperature) << i;
    EXPECT_FALSE(serial[i].displacement.empty());
  }
}

}  // namespace
