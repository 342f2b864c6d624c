// Hungarian assignment (seed 004's baseline): the solver against brute force, and the associator
// on hand-made problems.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "association_fixtures.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/nn.h"

namespace ekf_slam {
namespace test_hungarian {

using assoc_test::Scene;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Least total cost over all injective row -> column maps (+inf when none is finite).
double bruteForce(const Eigen::MatrixXd& c, int row, std::vector<char>* used) {
  if (row == c.rows()) return 0.0;
  double best = kInf;
  for (int j = 0; j < c.cols(); ++j) {
    if ((*used)[j] || !(c(row, j) < kInf)) continue;
    (*used)[j] = 1;
    best = std::min(best, c(row, j) + bruteForce(c, row + 1, used));
    (*used)[j] = 0;
  }
  return best;
}

TEST(AssignmentSolver, OptimalOnRandomMatricesAgainstBruteForce) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::uniform_int_distribution<int> dim(1, 6);
  AssignmentSolver solver;
  int infeasible = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int rows = dim(rng);
    const int cols = rows + std::uniform_int_distribution<int>(0, 3)(rng);
    Eigen::MatrixXd c(rows, cols);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        // Integer costs make ties common; some entries forbidden.
        c(i, j) = trial % 2 ? std::floor(u(rng)) : u(rng);
        if (u(rng) < 2.5) c(i, j) = kInf;
      }
    }
    std::vector<int> assign;
    const double total = solver.solve(c, &assign);
    std::vector<char> used(cols, 0);
    const double expect = bruteForce(c, 0, &used);
    if (std::isinf(expect)) {
      ++infeasible;
      EXPECT_TRUE(std::isinf(total)) << trial;
      EXPECT_EQ(std::count(assign.begin(), assign.end(), -1), rows);
      continue;
    }
    ASSERT_NEAR(total, expect, 1e-9) << trial;
    // The assignment is a valid one with that cost.
    double sum = 0.0;
    std::vector<char> taken(cols, 0);
    for (int i = 0; i < rows; ++i) {
      ASSERT_GE(assign[i], 0);
      EXPECT_FALSE(taken[assign[i]]);
      taken[assign[i]] = 1;
      sum += c(i, assign[i]);
    }
    EXPECT_NEAR(sum, total, 1e-9);
  }
  EXPECT_GT(infeasible, 5);
  EXPECT_LT(infeasible, 200);
}

TEST(AssignmentSolver, EdgeCases) {
  AssignmentSolver solver;
  std::vector<int> assign;
  EXPECT_EQ(solver.solve(Eigen::MatrixXd(0, 3), &assign), 0.0);
  EXPECT_TRUE(assign.empty());
  EXPECT_TRUE(std::isinf(solver.solve(Eigen::MatrixXd::Zero(3, 2), &assign)));
  Eigen::MatrixXd c(2, 2);
  c << 1, 2, 3, 7;  // 1 + 7 = 8 vs 2 + 3 = 5
  EXPECT_DOUBLE_EQ(solver.solve(c, &assign), 5.0);
  EXPECT_EQ(assign, (std::vector<int>{1, 0}));
}

AssociationResult runHungarian(const Scene& s) {
  Hungarian h;
  h.configure(MapParameterSource());
  return h.associate(s.context());
}

TEST(Hungarian, UnambiguousPairs) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 20; ++trial) {
    Scene s;
    assoc_test::unambiguousScene(&s, trial == 0 ? nullptr : &rng);
    const AssociationResult r = runHungarian(s);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
  }
}

TEST(Hungarian, OptimalAssignmentWhereGreedyNNInterferes) {
  // Observation 0 lies between landmarks 0 and 1 (nearer 0); observation 1 sees only landmark 0.
  // NN puts both on landmark 0; the optimal one-to-one assignment gives 0 -> 1 and 1 -> 0.
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.addLandmark(Eigen::Vector2d(10, 0.8));
  s.build();
  s.observePoint(Eigen::Vector2d(10, 0.35), nullptr, 1);
  s.observePoint(Eigen::Vector2d(10, -0.15), nullptr, 0);
  const AssociationContext ctx = s.context();
  ASSERT_LT(ctx.individual(0, 1).mahalanobis, 5.99);
  ASSERT_GT(ctx.individual(1, 1).mahalanobis, 5.99);
  NN nn;
  nn.configure(MapParameterSource());
  const AssociationResult rn = nn.associate(ctx);
  EXPECT_EQ(rn.landmark[0], Scene::idOf(0));
  EXPECT_EQ(rn.landmark[1], Scene::idOf(0));
  const AssociationResult r = runHungarian(s);
  EXPECT_EQ(r.landmark[0], Scene::idOf(1));
  EXPECT_EQ(r.landmark[1], Scene::idOf(0));
}

TEST(Hungarian, LeavesAnObservationUnpairedWhenPairingCostsMoreThanTheGate) {
  // Two observations, one landmark: only one is paired (the cheaper one), the other pays the
  // dummy cost and is rejected (too close to be new).
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.build();
  s.observePoint(Eigen::Vector2d(10, 0.3));
  s.observeLandmark(0);
  const AssociationResult r = runHungarian(s);
  EXPECT_EQ(r.decision[0], Decision::kRejected);
  EXPECT_EQ(r.landmark[1], Scene::idOf(0));
}

TEST(Hungarian, MatchesBruteForceOnRandomScenes) {
  // The associator's total cost (M_ij per pairing, the gate per unpaired observation) is minimal.
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Hungarian h;
  h.configure(MapParameterSource());
  const double gate = h.gating().individual_gate;
  for (int trial = 0; trial < 60; ++trial) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.5, 0.5, 0.03);
    for (int j = 0; j < 5; ++j) {
      s.addLandmark(Eigen::Vector2d(5 + 5 * u(rng), -3 + 6 * u(rng)), assoc_test::diag2(0.1, 0.1));
    }
    s.build();
    s.observeAll(30.0, &rng);
    s.observePoint(Eigen::Vector2d(5 + 5 * u(rng), -3 + 6 * u(rng)), &rng);
    const AssociationContext ctx = s.context();
    const AssociationResult r = h.associate(ctx);
    const int m = static_cast<int>(s.observations.size());
    const int n = static_cast<int>(s.landmarks.size());
    Eigen::MatrixXd c = Eigen::MatrixXd::Constant(m, n + m, kInf);
    double got = 0.0;
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < n; ++j) {
        const double mij = ctx.individual(i, j).mahalanobis;
        if (mij <= gate) c(i, j) = mij;
      }
      c(i, n + i) = gate;
      got += r.decision[i] == Decision::kPaired ? c(i, s.ekf.indexOf(r.landmark[i])) : gate;
    }
    std::vector<char> used(n + m, 0);
    EXPECT_NEAR(got, bruteForce(c, 0, &used), 1e-9) << trial;
  }
}

TEST(Hungarian, ClutterEmptyMapEmptyScanBehind) { assoc_test::expectEdgeCases(runHungarian); }

}  // namespace test_hungarian
}  // namespace ekf_slam
