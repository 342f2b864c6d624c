// Reweighted random walks on tiny graphs with a known answer, and the Sinkhorn step.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "ekf_slam/core/graph_matching/reweighted_random_walks.h"

namespace ekf_slam {
namespace test_reweighted_random_walks {

// All rows x cols candidates of two point sets, node affinity `node(r, c)`, edge affinity from
// the agreement of pairwise distances (sigma 0.5).
MatchGraph fullGraph(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
                     const Eigen::MatrixXd& node) {
  MatchGraph g;
  g.clear(static_cast<int>(a.size()), static_cast<int>(b.size()));
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) g.addCandidate(r, c);
  }
  for (int x = 0; x < g.size(); ++x) {
    g.beginRow();
    for (int y = 0; y < g.size(); ++y) {
      if (x == y) {
        g.addEntry(y, node(g.row[x], g.col[x]));
      } else if (g.row[x] != g.row[y] && g.col[x] != g.col[y]) {
        const double e = (a[g.row[x]] - a[g.row[y]]).norm() - (b[g.col[x]] - b[g.col[y]]).norm();
        g.addEntry(y, std::exp(-0.5 * e * e / 0.25));
      }
    }
  }
  g.finish();
  return g;
}

// Index of the best-scoring column of each row.
std::vector<int> argmaxPerRow(const MatchGraph& g, const Eigen::VectorXd& x) {
  std::vector<int> best(g.rows, -1);
  std::vector<double> score(g.rows, -1.0);
  for (int c = 0; c < g.size(); ++c) {
    if (x[c] > score[g.row[c]]) {
      score[g.row[c]] = x[c];
      best[g.row[c]] = g.col[c];
    }
  }
  return best;
}

TEST(ReweightedRandomWalks, FindsTheTriangleCorrespondence) {
  // A 3-4-5 triangle and the same triangle rotated, shifted and listed in another order.
  const std::vector<Eigen::Vector2d> a = {{0, 0}, {3, 0}, {0, 4}};
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(2.0).toRotationMatrix();
  const Eigen::Vector2d t(10, -5);
  const std::vector<Eigen::Vector2d> b = {rot * a[2] + t, rot * a[0] + t, rot * a[1] + t};
  MatchGraph g = fullGraph(a, b, Eigen::MatrixXd::Ones(3, 3));  // nodes tell nothing
  ReweightedRandomWalks rrw;
  Eigen::VectorXd x;
  const int iterations = rrw.run(g, RrwParams(), &x);
  EXPECT_GT(iterations, 1);
  EXPECT_LT(iterations, 300);  // converged
  EXPECT_NEAR(x.sum(), 1.0, 1e-12);
  EXPECT_EQ(argmaxPerRow(g, x), (std::vector<int>{1, 2, 0}));
}

TEST(ReweightedRandomWalks, EdgesOverruleAMisleadingNode) {
  // A square with one corner pulled out (distinct distances) and an extra landmark; the node
  // affinity prefers a wrong landmark for row 0, the pairwise distances the right one.
  const std::vector<Eigen::Vector2d> a = {{0, 0}, {10, 0}, {10, 10}, {0, 13}};
  const std::vector<Eigen::Vector2d> b = {{0, 0}, {10, 0}, {10, 10}, {0, 13}, {30, 30}};
  Eigen::MatrixXd node = Eigen::MatrixXd::Constant(4, 5, 0.5);
  node(0, 4) = 1.0;
  node(0, 0) = 0.1;
  MatchGraph g = fullGraph(a, b, node);
  ReweightedRandomWalks rrw;
  Eigen::VectorXd x;
  rrw.run(g, RrwParams(), &x);
  EXPECT_EQ(argmaxPerRow(g, x), (std::vector<int>{0, 1, 2, 3}));
}

TEST(ReweightedRandomWalks, SinkhornMakesRowsAndColumnsSumToOne) {
  MatchGraph g;
  g.clear(2, 3);
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) g.addCandidate(r, c);
  }
  Eigen::VectorXd a(6);
  a << 5, 1, 2, 1, 7, 3;
  ReweightedRandomWalks rrw;
  RrwParams p;
  p.sinkhorn_tolerance = 1e-12;
  p.sinkhorn_iterations = 10000;
  rrw.sinkhorn(g, p, &a);
  // Rows sum to one; columns to at most one (the dummy row takes the rest: 3 - 2 = 1 in total).
  EXPECT_NEAR(a.segment(0, 3).sum(), 1.0, 1e-9);
  EXPECT_NEAR(a.segment(3, 3).sum(), 1.0, 1e-9);
  for (int c = 0; c < 3; ++c) EXPECT_LE(a[c] + a[3 + c], 1.0 + 1e-9);
  EXPECT_GT(a[0], a[1]);
  EXPECT_GT(a[4], a[3]);
}

TEST(ReweightedRandomWalks, EmptyGraphGivesNoScores) {
  MatchGraph g;
  g.clear(0, 4);
  g.finish();
  ReweightedRandomWalks rrw;
  Eigen::VectorXd x;
  EXPECT_EQ(rrw.run(g, RrwParams(), &x), 0);
  EXPECT_EQ(x.size(), 0);
}

}  // namespace test_reweighted_random_walks
}  // namespace ekf_slam
