// Message <-> pipeline conversions: yaw from quaternions, odometry, observation covariances,
// LandmarkArray and AssociationStats contents.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/ros/conversions.h"

namespace test_conversions {

using namespace ekf_slam;

geometry_msgs::Pose poseWithQuaternion(double x, double y, double z, double w) {
  geometry_msgs::Pose p;
  p.position.x = 1.5;
  p.position.y = -2.0;
  p.position.z = 7.0;  // ignored: planar
  p.orientation.x = x;
  p.orientation.y = y;
  p.orientation.z = z;
  p.orientation.w = w;
  return p;
}

TEST(Conversions, YawFromQuaternion) {
  for (double yaw : {0.0, 0.3, -1.2, 2.9, -3.1, M_PI / 2}) {
    const geometry_msgs::Pose p =
        poseWithQuaternion(0.0, 0.0, std::sin(yaw / 2), std::cos(yaw / 2));
    const Eigen::Vector3d q = toPose2(p);
    EXPECT_DOUBLE_EQ(q.x(), 1.5);
    EXPECT_DOUBLE_EQ(q.y(), -2.0);
    EXPECT_NEAR(q.z(), yaw, 1e-12) << "yaw " << yaw;
  }
  // Yaw pi is reported as +-pi.
  EXPECT_NEAR(std::abs(toPose2(poseWithQuaternion(0, 0, 1, 0)).z()), M_PI, 1e-12);
}

TEST(Conversions, YawIgnoresQuaternionScale) {
  const double yaw = 0.7;
  const geometry_msgs::Pose p =
      poseWithQuaternion(0.0, 0.0, 2.0 * std::sin(yaw / 2), 2.0 * std::cos(yaw / 2));
  EXPECT_NEAR(toPose2(p).z(), yaw, 1e-12);
}

TEST(Conversions, YawOfTiltedQuaternion) {
  // Roll 0.2 then yaw 1.0 (ZYX): the heading is still 1.0.
  const double roll = 0.2, yaw = 1.0;
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  const geometry_msgs::Pose p = poseWithQuaternion(sr * cy, sr * sy, cr * sy, cr * cy);
  EXPECT_NEAR(toPose2(p).z(), yaw, 1e-12);
}

TEST(Conversions, TransformAndRoundTrip) {
  geometry_msgs::Transform t;
  t.translation.x = 3.78;
  t.translation.y = 0.5;
  t.rotation.z = std::sin(-0.4 / 2);
  t.rotation.w = std::cos(-0.4 / 2);
  const Eigen::Vector3d p = toPose2(t);
  EXPECT_DOUBLE_EQ(p.x(), 3.78);
  EXPECT_DOUBLE_EQ(p.y(), 0.5);
  EXPECT_NEAR(p.z(), -0.4, 1e-12);

  const Eigen::Vector3d pose(4.0, -1.0, 2.5);
  const geometry_msgs::Pose msg = toPoseMsg(pose);
  EXPECT_DOUBLE_EQ(msg.position.z, 0.0);
  EXPECT_NEAR(msg.orientation.x * msg.orientation.x + msg.orientation.y * msg.orientation.y +
                  msg.orientation.z * msg.orientation.z + msg.orientation.w * msg.orientation.w,
              1.0, 1e-12);
  EXPECT_TRUE(toPose2(msg).isApprox(pose, 1e-12));
}

TEST(Conversions, PlanarCovarianceIn6x6) {
  Eigen::Matrix3d P;
  P << 1, 2, 3, 2, 4, 5, 3, 5, 6;
  const boost::array<double, 36> c = toCovarianceMsg(P, 1e-6);
  const int idx[3] = {0, 1, 5};  // x, y, yaw
  for (int r = 0; r < 3; ++r) {
    for (int q = 0; q < 3; ++q) EXPECT_EQ(c[idx[r] * 6 + idx[q]], P(r, q));
  }
  for (int k = 2; k < 5; ++k) EXPECT_EQ(c[k * 6 + k], 1e-6);  // z, roll, pitch
  EXPECT_EQ(c[2 * 6 + 3], 0.0);
  EXPECT_EQ(toCovarianceMsg(P)[3 * 6 + 3], 0.0);
  const geometry_msgs::Quaternion q = toQuaternionMsg(M_PI / 2);
  EXPECT_NEAR(q.z, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(q.w, std::sqrt(0.5), 1e-12);
  EXPECT_EQ(q.x, 0.0);
}

TEST(Conversions, Odometry) {
  nav_msgs::Odometry msg;
  msg.header.stamp = ros::Time(20, 967000000);
  msg.pose.pose = toPoseMsg(Eigen::Vector3d(10.0, 5.0, -0.25));
  msg.twist.twist.linear.x = 3.5;
  msg.twist.twist.linear.y = 9.0;  // not part of the planar model
  msg.twist.twist.angular.z = -0.1;
  const OdometryInput in = toOdometryInput(msg);
  EXPECT_NEAR(in.stamp, 20.967, 1e-9);
  EXPECT_DOUBLE_EQ(in.twist.x(), 3.5);
  EXPECT_DOUBLE_EQ(in.twist.y(), -0.1);
  EXPECT_NEAR(in.pose.x(), 10.0, 1e-12);
  EXPECT_NEAR(in.pose.y(), 5.0, 1e-12);
  EXPECT_NEAR(in.pose.z(), -0.25, 1e-12);
}

TEST(Conversions, ObservationCovarianceAndTruth) {
  LandmarkObservationArray msg;
  msg.observations.resize(3);
  msg.observations[0].range = 12.0;
  msg.observations[0].bearing = 0.3;
  msg.observations[0].covariance = {0.25, 0.01, 0.01, 0.0004};
  msg.observations[0].descriptor = 0.4;
  msg.observations[0].has_truth_id = true;
  msg.observations[0].truth_id = 17;
  msg.observations[1].range = 5.0;
  msg.observations[1].bearing = -1.0;  // covariance left at zero: "use the default"
  msg.observations[1].descriptor = std::numeric_limits<double>::quiet_NaN();
  msg.observations[2].range = 7.0;
  msg.observations[2].has_truth_id = true;
  msg.observations[2].truth_id = -3;  // clutter

  std::vector<std::int64_t> truth;
  const std::vector<Observation> obs = toObservations(msg, &truth);
  ASSERT_EQ(obs.size(), 3u);
  EXPECT_DOUBLE_EQ(obs[0].z.x(), 12.0);
  EXPECT_DOUBLE_EQ(obs[0].z.y(), 0.3);
  EXPECT_DOUBLE_EQ(obs[0].R(0, 0), 0.25);
  EXPECT_DOUBLE_EQ(obs[0].R(0, 1), 0.01);
  EXPECT_DOUBLE_EQ(obs[0].R(1, 0), 0.01);
  EXPECT_DOUBLE_EQ(obs[0].R(1, 1), 0.0004);
  EXPECT_DOUBLE_EQ(obs[0].descriptor, 0.4);
  EXPECT_TRUE(obs[1].R.isZero()) << "an unset covariance must stay zero for the pipeline";
  EXPECT_TRUE(std::isnan(obs[1].descriptor));
  ASSERT_EQ(truth.size(), 3u);
  EXPECT_EQ(truth[0], 17);
  EXPECT_EQ(truth[1], kNoTruthId);  // -1 is a real id (the first mover)
  EXPECT_EQ(truth[2], -3);

  // No truth vector: fine too.
  EXPECT_EQ(toObservations(msg).size(), 3u);

  // Round trip of one observation.
  const LandmarkObservation back = toObservationMsg(obs[0]);
  EXPECT_DOUBLE_EQ(back.range, 12.0);
  EXPECT_DOUBLE_EQ(back.bearing, 0.3);
  EXPECT_DOUBLE_EQ(back.covariance[1], 0.01);
  EXPECT_DOUBLE_EQ(back.covariance[3], 0.0004);
  EXPECT_DOUBLE_EQ(back.descriptor, 0.4);
  EXPECT_FALSE(back.has_truth_id);
}

// Cartesian observations: (x, y) and the covariance in (x, y); an unknown model becomes a
// non-finite observation (rejected and counted by the pipeline).
TEST(Conversions, CartesianObservations) {
  LandmarkObservationArray msg;
  msg.observations.resize(2);
  msg.observations[0].model = LandmarkObservation::CARTESIAN;
  msg.observations[0].x = 2.0;
  msg.observations[0].y = -0.5;
  msg.observations[0].covariance = {0.01, 0.002, 0.002, 0.02};
  msg.observations[1].model = 7;
  const std::vector<Observation> obs = toObservations(msg);
  ASSERT_EQ(obs.size(), 2u);
  EXPECT_EQ(obs[0].kind, MeasurementKind::kCartesian);
  EXPECT_DOUBLE_EQ(obs[0].z.x(), 2.0);
  EXPECT_DOUBLE_EQ(obs[0].z.y(), -0.5);
  EXPECT_DOUBLE_EQ(obs[0].R(0, 1), 0.002);
  EXPECT_FALSE(obs[1].z.allFinite());
  const LandmarkObservation back = toObservationMsg(obs[0]);
  EXPECT_EQ(back.model, LandmarkObservation::CARTESIAN);
  EXPECT_DOUBLE_EQ(back.x, 2.0);
  EXPECT_DOUBLE_EQ(back.y, -0.5);
  EXPECT_NEAR(back.range, std::hypot(2.0, 0.5), 1e-12);
  EXPECT_EQ(toObservationMsg(Observation()).model, LandmarkObservation::RANGE_BEARING);
}

TEST(Conversions, AssociationStats) {
  ScanReport report;
  report.scan = 41;
  report.observations.resize(4);
  report.observations[0].z = Eigen::Vector2d(10.0, 0.1);
  report.observations[3].z = Eigen::Vector2d(20.0, -0.5);
  report.association.resize(4);
  report.association.pair(0, 7);
  report.association.decision[1] = Decision::kNew;
  report.association.landmark[1] = 12;
  report.association.decision[2] = Decision::kTentative;
  report.association.decision[3] = Decision::kRejected;
  report.removed = {3, 5};
  report.association_s = 0.001;
  report.update_s = 0.002;
  report.nis = 1.5;
  report.nis_dof = 2;

  const AssociationStats msg =
      toAssociationStats(report, "ekf_slam/NN", 13, "map", ros::Time(5, 0));
  EXPECT_EQ(msg.header.frame_id, "map");
  EXPECT_EQ(msg.header.stamp, ros::Time(5, 0));
  EXPECT_EQ(msg.associator, "ekf_slam/NN");
  EXPECT_EQ(msg.scan, 41u);
  ASSERT_EQ(msg.observations.size(), 4u);
  EXPECT_DOUBLE_EQ(msg.observations[3].range, 20.0);
  ASSERT_EQ(msg.decision.size(), 4u);
  EXPECT_EQ(msg.decision[0], AssociationStats::PAIRED);
  EXPECT_EQ(msg.decision[1], AssociationStats::NEW);
  EXPECT_EQ(msg.decision[2], AssociationStats::TENTATIVE);
  EXPECT_EQ(msg.decision[3], AssociationStats::REJECTED);
  ASSERT_EQ(msg.landmark_id.size(), 4u);
  EXPECT_EQ(msg.landmark_id[0], 7);
  EXPECT_EQ(msg.landmark_id[1], 12);
  EXPECT_EQ(msg.landmark_id[2], -1);
  EXPECT_EQ(msg.landmark_id[3], -1);
  ASSERT_EQ(msg.removed.size(), 2u);
  EXPECT_EQ(msg.removed[1], 5);
  EXPECT_DOUBLE_EQ(msg.association_time, 0.001);
  EXPECT_DOUBLE_EQ(msg.update_time, 0.002);
  EXPECT_DOUBLE_EQ(msg.nis, 1.5);
  EXPECT_EQ(msg.nis_dof, 2u);
  EXPECT_EQ(msg.landmarks, 13u);
}

TEST(Conversions, LandmarkArrayFromPipeline) {
  auto nn = std::make_shared<NN>();
  nn->configure(MapParameterSource());
  PipelineConfig config;
  config.min_observation_range = 0.5;
  SlamPipeline pipeline(config, nn);

  // Two trees on an empty map: both become landmarks.
  std::vector<Observation> obs(2);
  obs[0].z = Eigen::Vector2d(10.0, 0.0);
  obs[0].R = Eigen::Matrix2d::Zero();  // default noise
  obs[0].descriptor = 0.5;
  obs[1].z = Eigen::Vector2d(5.0, M_PI / 2);
  obs[1].R = Eigen::Vector2d(0.04, 0.0001).asDiagonal();
  const ScanReport report = pipeline.processObservations(1.0, obs);
  ASSERT_EQ(pipeline.ekf().numLandmarks(), 2u);

  const LandmarkArray msg = toLandmarkArray(pipeline, "map", ros::Time(1, 0));
  EXPECT_EQ(msg.header.frame_id, "map");
  EXPECT_EQ(msg.header.stamp, ros::Time(1, 0));
  ASSERT_EQ(msg.landmarks.size(), 2u);
  const EkfSlam& ekf = pipeline.ekf();
  for (std::size_t k = 0; k < 2; ++k) {
    const Landmark& lm = msg.landmarks[k];
    EXPECT_EQ(lm.id, ekf.landmarkIds()[k]);
    EXPECT_DOUBLE_EQ(lm.x, ekf.landmark(k).x());
    EXPECT_DOUBLE_EQ(lm.y, ekf.landmark(k).y());
    const Eigen::Matrix2d P = ekf.landmarkCovariance(k);
    EXPECT_DOUBLE_EQ(lm.covariance[0], P(0, 0));
    EXPECT_DOUBLE_EQ(lm.covariance[1], P(0, 1));
    EXPECT_DOUBLE_EQ(lm.covariance[2], P(1, 0));
    EXPECT_DOUBLE_EQ(lm.covariance[3], P(1, 1));
    EXPECT_GT(lm.covariance[0], 0.0);
    EXPECT_EQ(lm.evidence, 0);  // NN keeps no evidence counter
  }
  // The first tree sits 10 m ahead of the (zero) initial pose, the second 5 m to the left.
  EXPECT_NEAR(msg.landmarks[0].x, 10.0, 1e-9);
  EXPECT_NEAR(msg.landmarks[0].y, 0.0, 1e-9);
  EXPECT_NEAR(msg.landmarks[1].x, 0.0, 1e-9);
  EXPECT_NEAR(msg.landmarks[1].y, 5.0, 1e-9);
  EXPECT_NEAR(msg.landmarks[0].diameter, 0.5, 1e-12);
  EXPECT_TRUE(std::isnan(msg.landmarks[1].diameter));

  const AssociationStats stats =
      toAssociationStats(report, "ekf_slam/NN", ekf.numLandmarks(), "map", ros::Time(1, 0));
  ASSERT_EQ(stats.decision.size(), 2u);
  EXPECT_EQ(stats.decision[0], AssociationStats::NEW);
  EXPECT_EQ(stats.landmark_id[0], msg.landmarks[0].id);
  EXPECT_EQ(stats.landmarks, 2u);
}

}  // namespace test_conversions
