// associationCeiling on crafted scans: two landmarks at the same range, 1 deg apart, seen with a
// 30 deg bearing noise cannot be told apart (ceiling near 0.5); far apart they always can.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/evaluation/association_ceiling.h"

namespace ekf_slam {
namespace test_association_ceiling {

struct Shares {
  double joint = 0.0, individual = 0.0, marginal = 0.0, marginal_expected = 0.0;
  int joint_collisions = 0, individual_collisions = 0;
};

// `scans` scans of every landmark seen from the origin with range sd 1 m and bearing sd
// `sigma_bearing`; observation i is landmark i's return.
Shares ceilingShares(const std::vector<Eigen::Vector2d>& landmarks, double sigma_bearing,
                     int scans) {
  const RangeBearingModel model;
  const Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  sim::Random noise(7), chain(11);
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  R(0, 0) = 1.0;
  R(1, 1) = sigma_bearing * sigma_bearing;
  Shares s;
  double n = 0.0;
  for (int k = 0; k < scans; ++k) {
    std::vector<Observation> obs;
    for (const Eigen::Vector2d& l : landmarks) {
      const Eigen::Vector2d z = model.predict(pose, l);
      obs.push_back({{z(0) + noise.normal(), wrapAngle(z(1) + sigma_bearing * noise.normal())}, R});
    }
    const ScanCeiling c = associationCeiling(model, pose, landmarks, obs, {}, &chain);
    for (std::size_t i = 0; i < obs.size(); ++i) {
      s.joint += c.joint[i] == static_cast<int>(i);
      s.individual += c.individual[i] == static_cast<int>(i);
      s.marginal += c.marginal[i] == static_cast<int>(i);
      s.marginal_expected += c.marginal_probability[i];
      n += 1.0;
    }
    s.joint_collisions += c.joint.size() == 2 && c.joint[0] == c.joint[1];
    s.individual_collisions += c.individual.size() == 2 && c.individual[0] == c.individual[1];
  }
  s.joint /= n;
  s.individual /= n;
  s.marginal /= n;
  s.marginal_expected /= n;
  return s;
}

Eigen::Vector2d polar(double r, double deg) {
  return {r * std::cos(deg2rad(deg)), r * std::sin(deg2rad(deg))};
}

TEST(AssociationCeiling, SameRangeOneDegreeApartIsAmbiguous) {
  const Shares s = ceilingShares({polar(100.0, 0.0), polar(100.0, 1.0)}, deg2rad(30.0), 2000);
  EXPECT_GT(s.joint, 0.45);
  EXPECT_LT(s.joint, 0.75);
  EXPECT_GT(s.individual, 0.45);
  EXPECT_LT(s.individual, 0.75);
  // One-to-one: the joint assignment never gives both returns to one landmark; alone, each
  // return often picks the same one as the other.
  EXPECT_EQ(s.joint_collisions, 0);
  EXPECT_GT(s.individual_collisions, 400);
  // The posterior marginals are calibrated: their expected share matches the realised one.
  EXPECT_NEAR(s.marginal, s.marginal_expected, 0.03);
  EXPECT_GT(s.marginal, 0.45);
}

TEST(AssociationCeiling, FarApartIsAlwaysRight) {
  // Opposite sides: a return alone is closer to the other landmark once its bearing error passes
  // 90 deg (3 sd: 0.3 %); both at once, which the joint assignment needs, almost never.
  const Shares apart = ceilingShares({polar(100.0, 0.0), polar(100.0, 180.0)}, deg2rad(30.0), 1000);
  EXPECT_GT(apart.joint, 0.9995);
  EXPECT_GT(apart.individual, 0.99);
  EXPECT_LT(apart.individual, apart.joint);
  EXPECT_GT(apart.marginal, 0.9995);
  // The same bearing but 20 range sd apart: the range tells them apart.
  const Shares deeper = ceilingShares({polar(100.0, 0.0), polar(120.0, 0.0)}, deg2rad(30.0), 500);
  EXPECT_DOUBLE_EQ(deeper.joint, 1.0);
  EXPECT_DOUBLE_EQ(deeper.individual, 1.0);
  EXPECT_DOUBLE_EQ(deeper.marginal, 1.0);
  EXPECT_NEAR(deeper.marginal_expected, 1.0, 1e-9);
}

TEST(AssociationCeiling, MarginalsBeatTheJointAssignmentOnCount) {
  // Three returns of a tight cluster: the decision that maximises the expected count is right at
  // least as often as the most probable whole scan (up to sampling).
  const Shares s =
      ceilingShares({polar(100.0, 0.0), polar(100.0, 4.0), polar(100.5, 8.0)}, deg2rad(6.0), 2000);
  EXPECT_GT(s.marginal, s.joint - 0.01);
  EXPECT_LT(s.joint, 0.95);
  EXPECT_NEAR(s.marginal, s.marginal_expected, 0.03);
}

TEST(AssociationCeiling, BadInputThrows) {
  const RangeBearingModel model;
  const std::vector<Eigen::Vector2d> one = {{10.0, 0.0}};
  const Observation z{{10.0, 0.0}, Eigen::Matrix2d::Identity()};
  sim::Random rng(1);
  EXPECT_THROW(associationCeiling(model, Eigen::Vector3d::Zero(), one, {z, z}, {}, &rng),
               std::invalid_argument);
  EXPECT_THROW(associationCeiling(model, Eigen::Vector3d::Zero(), one, {z}, {}, nullptr),
               std::invalid_argument);
  Observation bad = z;
  bad.z(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(associationCeiling(model, Eigen::Vector3d::Zero(), one, {bad}, {}, &rng),
               std::invalid_argument);
  CeilingOptions none;
  none.sweeps = 0;
  const ScanCeiling c = associationCeiling(model, Eigen::Vector3d::Zero(), one, {z}, none);
  EXPECT_EQ(c.joint, std::vector<int>{0});
  EXPECT_TRUE(c.marginal.empty());
}

}  // namespace test_association_ceiling
}  // namespace ekf_slam
