// LandmarkIndex: queries equal brute force on random maps; sync follows adds, removals, moves.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"

namespace ekf_slam {
namespace test_landmark_index {

EkfSlam makeMap(const std::vector<Eigen::Vector2d>& points) {
  const int n = static_cast<int>(points.size());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3 + 2 * n);
  for (int k = 0; k < n; ++k) x.segment<2>(3 + 2 * k) = points[k];
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(3 + 2 * n, 3 + 2 * n) * 0.01;
  std::vector<LandmarkId> ids(n);
  for (int k = 0; k < n; ++k) ids[k] = 10 * k + 7;  // ids unlike indices
  EkfSlam ekf;
  ekf.setState(x, P, ids);
  return ekf;
}

std::vector<int> bruteForce(const EkfSlam& ekf, const Eigen::Vector2d& c, double r) {
  std::vector<int> out;
  for (int k = 0; k < static_cast<int>(ekf.numLandmarks()); ++k) {
    if ((ekf.landmark(k) - c).norm() <= r) out.push_back(k);
  }
  return out;
}

std::vector<int> query(const LandmarkIndex& index, const EkfSlam& ekf, const Eigen::Vector2d& c,
                       double r) {
  std::vector<int> out;
  index.query(ekf, c, r, &out);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(LandmarkIndex, QueryEqualsBruteForceOnRandomMaps) {
  std::mt19937 rng(42);
  for (double cell : {0.7, 5.0, 10.0, 40.0}) {
    std::uniform_real_distribution<double> pos(-200.0, 200.0);
    std::vector<Eigen::Vector2d> pts(800);
    for (auto& p : pts) p = Eigen::Vector2d(pos(rng), pos(rng));
    // Points exactly on cell borders and duplicates.
    pts.push_back(Eigen::Vector2d(0.0, 0.0));
    pts.push_back(Eigen::Vector2d(10.0, -10.0));
    pts.push_back(Eigen::Vector2d(10.0, -10.0));
    const EkfSlam ekf = makeMap(pts);
    LandmarkIndex index(cell);
    index.sync(ekf);
    EXPECT_EQ(index.size(), pts.size());
    std::uniform_real_distribution<double> rad(0.0, 60.0);
    std::size_t total = 0;
    for (int q = 0; q < 300; ++q) {
      const Eigen::Vector2d c(pos(rng) * 1.2, pos(rng) * 1.2);
      const double r = q == 0 ? 1000.0 : rad(rng);
      const auto expected = bruteForce(ekf, c, r);
      total += expected.size();
      ASSERT_EQ(query(index, ekf, c, r), expected) << "cell " << cell << " query " << q;
    }
    EXPECT_GT(total, 1000u);  // the queries were not all empty
    // Radius 0 on a landmark finds exactly the landmarks at that point.
    EXPECT_EQ(query(index, ekf, Eigen::Vector2d(10.0, -10.0), 0.0).size(), 2u);
  }
}

TEST(LandmarkIndex, SyncAfterAddRemoveMove) {
  EkfSlam ekf = makeMap({Eigen::Vector2d(1, 1), Eigen::Vector2d(50, 0), Eigen::Vector2d(-30, 20)});
  LandmarkIndex index(10.0);
  index.sync(ekf);
  ASSERT_EQ(index.size(), 3u);
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(0, 0), 5.0), std::vector<int>({0}));

  // Add: an inserted landmark is found after sync.
  const LandmarkId added =
      ekf.insertLandmark(Eigen::Vector2d(2, -2), Eigen::Matrix2d::Identity() * 0.1);
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(0, 0), 5.0), std::vector<int>({0}));  // not yet
  index.sync(ekf);
  EXPECT_EQ(index.size(), 4u);
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(0, 0), 5.0),
            std::vector<int>({0, ekf.indexOf(added)}));

  // Remove: indices shift; the query reports current state-order indices.
  ASSERT_TRUE(ekf.removeLandmark(7));  // the one at (1, 1)
  index.sync(ekf);
  EXPECT_EQ(index.size(), 3u);
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(0, 0), 5.0), std::vector<int>({ekf.indexOf(added)}));
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(50, 0), 1.0), std::vector<int>({ekf.indexOf(17)}));

  // Move: a landmark whose estimate jumps into another cell is re-binned.
  Eigen::VectorXd x = ekf.mean();
  const int k = ekf.indexOf(17);
  x.segment<2>(ekf.stateRow(k)) = Eigen::Vector2d(-100.0, -100.0);
  ekf.setState(x, ekf.covariance(), ekf.landmarkIds());
  index.sync(ekf);
  EXPECT_EQ(index.size(), 3u);
  EXPECT_TRUE(query(index, ekf, Eigen::Vector2d(50, 0), 5.0).empty());
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(-100, -100), 1.0), std::vector<int>({k}));

  // A removal plus an addition in one step (same count, different ids).
  ASSERT_TRUE(ekf.removeLandmark(27));  // at (-30, 20)
  const LandmarkId again =
      ekf.insertLandmark(Eigen::Vector2d(-31, 21), Eigen::Matrix2d::Identity() * 0.1);
  index.sync(ekf);
  EXPECT_EQ(index.size(), 3u);
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(-30, 20), 3.0),
            std::vector<int>({ekf.indexOf(again)}));
  // Everything, against brute force.
  EXPECT_EQ(query(index, ekf, Eigen::Vector2d(0, 0), 500.0),
            bruteForce(ekf, Eigen::Vector2d(0, 0), 500.0));

  index.clear();
  EXPECT_EQ(index.size(), 0u);
  EXPECT_TRUE(query(index, ekf, Eigen::Vector2d(0, 0), 500.0).empty());
}

TEST(LandmarkIndex, RandomEditsStayConsistent) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-100.0, 100.0);
  EkfSlam ekf;
  LandmarkIndex index(8.0);
  for (int step = 0; step < 400; ++step) {
    const int action = static_cast<int>(rng() % 3);
    if (action == 0 || ekf.numLandmarks() < 5) {
      ekf.insertLandmark(Eigen::Vector2d(pos(rng), pos(rng)), Eigen::Matrix2d::Identity());
    } else if (action == 1) {
      const auto& ids = ekf.landmarkIds();
      ekf.removeLandmark(ids[rng() % ids.size()]);
    } else {
      Eigen::VectorXd x = ekf.mean();
      const int k = static_cast<int>(rng() % ekf.numLandmarks());
      x.segment<2>(ekf.stateRow(k)) += Eigen::Vector2d(pos(rng), pos(rng)) * 0.1;
      ekf.setState(x, ekf.covariance(), ekf.landmarkIds());
    }
    index.sync(ekf);
    ASSERT_EQ(index.size(), ekf.numLandmarks());
    const Eigen::Vector2d c(pos(rng), pos(rng));
    ASSERT_EQ(query(index, ekf, c, 25.0), bruteForce(ekf, c, 25.0)) << "step " << step;
  }
}

TEST(LandmarkIndex, RejectsBadCellSize) {
  EXPECT_THROW(LandmarkIndex(0.0), std::invalid_argument);
  EXPECT_THROW(LandmarkIndex(-1.0), std::invalid_argument);
}

}  // namespace test_landmark_index
}  // namespace ekf_slam
