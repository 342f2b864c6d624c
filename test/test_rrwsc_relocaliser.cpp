// The RRW&SC relocaliser (ROS-free): a kidnapped scan found without a prior, with a prior, with a
// sensor offset; a symmetric map answered kAmbiguous; never a confident wrong pose.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"
#include "rrwsc_fixtures.h"

namespace ekf_slam {
namespace test_rrwsc_relocaliser {

std::vector<MapLandmark> mapOf(const std::vector<Eigen::Vector2d>& points, double sigma) {
  std::vector<MapLandmark> map;
  for (std::size_t k = 0; k < points.size(); ++k) {
    MapLandmark l;
    l.id = 1000 + static_cast<LandmarkId>(k);
    l.position = points[k];
    l.covariance = sigma * sigma * Eigen::Matrix2d::Identity();
    map.push_back(l);
  }
  return map;
}

double nees(const RelocalisationResult& r, const Eigen::Vector3d& truth) {
  Eigen::Vector3d e = r.pose - truth;
  e.z() = wrapAngle(e.z());
  return e.dot(r.covariance.inverse() * e);
}

RRWSCRelocaliser configured(const std::vector<MapLandmark>& map) {
  RRWSCRelocaliser r;
  r.configure(MapParameterSource());
  r.setMap(map);
  return r;
}

TEST(RRWSCRelocaliser, FindsKidnappedScansWithoutAPrior) {
  const auto points = rrwsc_test::randomMap(40, 100.0, 10.0, 3);
  RRWSCRelocaliser reloc = configured(mapOf(points, 0.2));
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-80.0, 80.0), yaw(-M_PI, M_PI);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Vector3d pose(u(rng), u(rng), yaw(rng));
    const auto scan =
        rrwsc_test::scanOf(points, pose, {0.1, deg2rad(3.0)}, trial, {trial, 20 + trial});
    const RelocalisationResult r =
        reloc.relocalise(scan.observations, Eigen::Vector3d::Zero(), nullptr);
    ASSERT_EQ(r.status, RelocalisationStatus::kFound) << trial << ": " << r.reason;
    EXPECT_LT((r.pose.head<2>() - pose.head<2>()).norm(), 0.5) << trial;
    EXPECT_LT(std::abs(wrapAngle(r.pose.z() - pose.z())), 0.02) << trial;
    EXPECT_LT(nees(r, pose), 25.0) << trial;  // the covariance is not far too optimistic
    int right = 0;
    for (std::size_t i = 0; i < scan.truth.size(); ++i) {
      if (r.landmark[i] != kNoLandmark) {
        EXPECT_EQ(r.landmark[i], 1000 + scan.truth[i]) << trial;
      }
      right += r.landmark[i] == 1000 + scan.truth[i];
    }
    EXPECT_GE(right, 34) << trial;  // of 38; far ones with 3 deg noise may miss the gate
    EXPECT_GE(r.hypothesis_size, 34);
    EXPECT_GT(r.covariance(0, 0), 0.0);
    EXPECT_LT(r.covariance(0, 0), 0.25);
  }
}

TEST(RRWSCRelocaliser, UsesAPriorAndTheSensorOffset) {
  const auto points = rrwsc_test::randomMap(60, 150.0, 10.0, 8);
  RRWSCRelocaliser reloc = configured(mapOf(points, 0.1));
  const Eigen::Vector3d offset(3.78, 0.5, 0.05);
  const Eigen::Vector3d vehicle(20.0, -30.0, 2.5);
  const Eigen::Vector2d s_xy =
      vehicle.head<2>() + Eigen::Rotation2Dd(vehicle.z()).toRotationMatrix() * offset.head<2>();
  const Eigen::Vector3d sensor(s_xy.x(), s_xy.y(), vehicle.z() + offset.z());
  // A 60 m sensor: only the landmarks in reach are seen.
  std::vector<int> hidden;
  for (int j = 0; j < 60; ++j) {
    if ((points[j] - s_xy).norm() > 60.0) hidden.push_back(j);
  }
  const auto scan = rrwsc_test::scanOf(points, sensor, {0.05, deg2rad(1.0)}, 2, hidden);
  ASSERT_GE(scan.observations.size(), 6u);
  PosePrior prior;
  prior.mean = vehicle + Eigen::Vector3d(4.0, -3.0, 0.3);
  prior.covariance = Eigen::Vector3d(25.0, 25.0, 0.1).asDiagonal();
  for (const PosePrior* p : std::vector<const PosePrior*>{nullptr, &prior}) {
    const RelocalisationResult r = reloc.relocalise(scan.observations, offset, p);
    ASSERT_EQ(r.status, RelocalisationStatus::kFound) << r.reason;
    EXPECT_LT((r.pose.head<2>() - vehicle.head<2>()).norm(), 0.3);
    EXPECT_LT(std::abs(wrapAngle(r.pose.z() - vehicle.z())), 0.01);
  }
}

TEST(RRWSCRelocaliser, SymmetricMapIsAmbiguous) {
  // Point symmetric about the origin: a scan from (0, 0, yaw) is explained as well from
  // (0, 0, yaw + pi).
  auto points = rrwsc_test::randomMap(12, 60.0, 12.0, 4);
  const std::size_t half = points.size();
  for (std::size_t k = 0; k < half; ++k) points.push_back(-points[k]);
  RRWSCRelocaliser reloc = configured(mapOf(points, 0.1));
  const auto scan = rrwsc_test::scanOf(points, {0.0, 0.0, 0.4}, {0.05, deg2rad(0.5)}, 1);
  const RelocalisationResult r =
      reloc.relocalise(scan.observations, Eigen::Vector3d::Zero(), nullptr);
  EXPECT_EQ(r.status, RelocalisationStatus::kAmbiguous) << r.reason;
}

TEST(RRWSCRelocaliser, NeverAConfidentWrongPose) {
  const auto points = rrwsc_test::randomMap(40, 100.0, 10.0, 12);
  RRWSCRelocaliser reloc = configured(mapOf(points, 0.3));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-80.0, 80.0), yaw(-M_PI, M_PI);
  std::uniform_int_distribution<int> pick(0, 39);
  int found = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const Eigen::Vector3d pose(u(rng), u(rng), yaw(rng));
    // Heavy occlusion (up to 34 of 40 hidden) and clutter.
    std::vector<int> hidden;
    const int n_hidden = 10 + trial;
    while (static_cast<int>(hidden.size()) < std::min(n_hidden, 34)) hidden.push_back(pick(rng));
    const auto scan = rrwsc_test::scanOf(points, pose, {0.1, deg2rad(3.0)}, trial, hidden, 5);
    const RelocalisationResult r =
        reloc.relocalise(scan.observations, Eigen::Vector3d::Zero(), nullptr);
    if (r.status != RelocalisationStatus::kFound) continue;
    ++found;
    // Right place: within 1 m, or within what its own covariance admits (few, noisy points).
    const double error = (r.pose.head<2>() - pose.head<2>()).norm();
    EXPECT_TRUE(error < 1.0 || nees(r, pose) < 16.27) << trial << ": " << error << " m";
    EXPECT_LT(error, 3.0) << trial;
    EXPECT_LT(std::abs(wrapAngle(r.pose.z() - pose.z())), 0.05) << trial;
  }
  EXPECT_GT(found, 10);
  // Clutter only, and too few observations.
  const auto clutter = rrwsc_test::scanOf({}, {0, 0, 0}, {0.1, 0.05}, 3, {}, 20);
  EXPECT_NE(reloc.relocalise(clutter.observations, Eigen::Vector3d::Zero(), nullptr).status,
            RelocalisationStatus::kFound);
  const auto few = rrwsc_test::scanOf({points[0], points[1], points[2]}, {0, 0, 0}, {0.1, 0.05}, 3);
  EXPECT_EQ(reloc.relocalise(few.observations, Eigen::Vector3d::Zero(), nullptr).status,
            RelocalisationStatus::kNotFound);
}

TEST(RRWSCRelocaliser, BadParametersNameTheParameter) {
  RRWSCRelocaliser r;
  EXPECT_THROW(r.configure(MapParameterSource(
                   std::map<std::string, std::string>{{"ambiguity_ratio", "1.5"}})),
               ParameterError);
  try {
    r.configure(MapParameterSource(std::map<std::string, std::string>{{"min_inliers", "1"}}));
    FAIL();
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find("min_inliers"), std::string::npos);
  }
  r.configure(MapParameterSource());
  EXPECT_EQ(r.name(), "RRWSC");
  EXPECT_EQ(r.params().matching.position_weight, 0.0);
}

}  // namespace test_rrwsc_relocaliser
}  // namespace ekf_slam
