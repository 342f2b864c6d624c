#include "ekf_slam/ros/conversions.h"

#include <cmath>
#include <limits>

#include <tf2/exceptions.h>

#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

Eigen::Vector3d toPose2(const geometry_msgs::Pose& pose) {
  const auto& q = pose.orientation;
  return Eigen::Vector3d(pose.position.x, pose.position.y, quaternionYaw(q.x, q.y, q.z, q.w));
}

Eigen::Vector3d toPose2(const geometry_msgs::Transform& transform) {
  const auto& q = transform.rotation;
  return Eigen::Vector3d(transform.translation.x, transform.translation.y,
                         quaternionYaw(q.x, q.y, q.z, q.w));
}

geometry_msgs::Pose toPoseMsg(const Eigen::Vector3d& pose) {
  geometry_msgs::Pose msg;
  msg.position.x = pose.x();
  msg.position.y = pose.y();
  msg.position.z = 0.0;
  msg.orientation = toQuaternionMsg(pose.z());
  return msg;
}

geometry_msgs::Quaternion toQuaternionMsg(double yaw) {
  const Eigen::Vector4d v = yawQuaternion(yaw);
  geometry_msgs::Quaternion q;
  q.x = v(0);
  q.y = v(1);
  q.z = v(2);
  q.w = v(3);
  return q;
}

boost::array<double, 36> toCovarianceMsg(const Eigen::Matrix3d& P, double other_variance) {
  boost::array<double, 36> c;
  c.fill(0.0);
  for (int k = 2; k < 5; ++k) c[k * 6 + k] = other_variance;
  const int idx[3] = {0, 1, 5};  // x, y, yaw
  for (int r = 0; r < 3; ++r) {
    for (int q = 0; q < 3; ++q) c[idx[r] * 6 + idx[q]] = P(r, q);
  }
  return c;
}

Eigen::Vector3d sensorOffset(const tf2::BufferCore& tf, const std::string& base_frame,
                             const std::string& frame) {
  if (frame == base_frame) return Eigen::Vector3d::Zero();
  // Without a frame the data could be anywhere on the vehicle: not taken for base_frame.
  if (frame.empty()) throw tf2::TransformException("the message has no header.frame_id");
  const Eigen::Vector3d offset =
      toPose2(tf.lookupTransform(base_frame, frame, ros::Time(0)).transform);
  if (!offset.allFinite()) throw tf2::TransformException("non-finite transform");
  return offset;
}

OdometryInput toOdometryInput(const nav_msgs::Odometry& msg) {
  OdometryInput odom;
  odom.stamp = msg.header.stamp.toSec();
  odom.twist = Eigen::Vector2d(msg.twist.twist.linear.x, msg.twist.twist.angular.z);
  odom.pose = toPose2(msg.pose.pose);
  // An all-zero quaternion (an unset field) has no yaw; atan2(0, 0) = 0 would pass for one.
  const auto& q = msg.pose.pose.orientation;
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  odom.orientation_valid = std::isfinite(norm2) && norm2 > 1e-12;
  return odom;
}

std::vector<Observation> toObservations(const LandmarkObservationArray& msg,
                                        std::vector<std::int64_t>* truth_ids) {
  std::vector<Observation> out(msg.observations.size());
  if (truth_ids) truth_ids->assign(msg.observations.size(), kNoTruthId);
  for (std::size_t i = 0; i < msg.observations.size(); ++i) {
    const LandmarkObservation& o = msg.observations[i];
    Observation& obs = out[i];
    if (o.model == LandmarkObservation::CARTESIAN) {
      obs.z = Eigen::Vector2d(o.x, o.y);
      obs.kind = MeasurementKind::kCartesian;
    } else if (o.model == LandmarkObservation::RANGE_BEARING) {
      obs.z = Eigen::Vector2d(o.range, o.bearing);
    } else {
      // Unknown model: not finite, so the pipeline rejects it with a count.
      obs.z.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
    // Copied as is: an all-zero covariance means "use the default noise" and the pipeline
    // substitutes it; a non-finite one is rejected there with a count.
    obs.R << o.covariance[0], o.covariance[1], o.covariance[2], o.covariance[3];
    obs.descriptor = o.descriptor;
    if (truth_ids && o.has_truth_id) (*truth_ids)[i] = o.truth_id;
  }
  return out;
}

LandmarkObservation toObservationMsg(const Observation& obs) {
  LandmarkObservation msg;
  if (obs.kind == MeasurementKind::kCartesian) {
    msg.model = LandmarkObservation::CARTESIAN;
    msg.x = obs.z.x();
    msg.y = obs.z.y();
    msg.range = std::hypot(msg.x, msg.y);
    msg.bearing = std::atan2(msg.y, msg.x);
  } else {
    msg.model = LandmarkObservation::RANGE_BEARING;
    msg.range = obs.z.x();
    msg.bearing = obs.z.y();
    msg.x = msg.range * std::cos(msg.bearing);
    msg.y = msg.range * std::sin(msg.bearing);
  }
  msg.covariance = {obs.R(0, 0), obs.R(0, 1), obs.R(1, 0), obs.R(1, 1)};
  msg.descriptor = obs.descriptor;
  msg.has_truth_id = false;
  msg.truth_id = -1;
  return msg;
}

LandmarkArray toLandmarkArray(const SlamPipeline& pipeline, const std::string& frame_id,
                              const ros::Time& stamp) {
  LandmarkArray msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  const EkfSlam& ekf = pipeline.ekf();
  const std::vector<LandmarkId>& ids = ekf.landmarkIds();
  msg.landmarks.resize(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) {
    Landmark& lm = msg.landmarks[k];
    const Eigen::Vector2d m = ekf.landmark(static_cast<int>(k));
    const Eigen::Matrix2d P = ekf.landmarkCovariance(static_cast<int>(k));
    const LandmarkInfo& info = pipeline.landmarkInfo(ids[k]);
    lm.id = ids[k];
    lm.x = m.x();
    lm.y = m.y();
    lm.covariance = {P(0, 0), P(0, 1), P(1, 0), P(1, 1)};
    lm.diameter = info.diameter;
    lm.evidence = pipeline.associator().evidence(ids[k]);
    lm.times_observed = info.times_observed;
  }
  return msg;
}

AssociationStats toAssociationStats(const ScanReport& report, const std::string& associator,
                                    std::size_t landmarks, const std::string& frame_id,
                                    const ros::Time& stamp) {
  AssociationStats msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  msg.associator = associator;
  msg.scan = report.scan;
  const std::size_t n = report.observations.size();
  msg.observations.reserve(n);
  for (const Observation& obs : report.observations)
    msg.observations.push_back(toObservationMsg(obs));
  msg.decision.assign(n, AssociationStats::REJECTED);
  msg.landmark_id.assign(n, -1);
  const AssociationResult& a = report.association;
  for (std::size_t i = 0; i < n && i < a.decision.size(); ++i) {
    switch (a.decision[i]) {
      case Decision::kPaired:
        msg.decision[i] = AssociationStats::PAIRED;
        break;
      case Decision::kNew:
        msg.decision[i] = AssociationStats::NEW;
        break;
      case Decision::kTentative:
        msg.decision[i] = AssociationStats::TENTATIVE;
        break;
      case Decision::kRejected:
        msg.decision[i] = AssociationStats::REJECTED;
        break;
    }
    const bool has_landmark = a.decision[i] == Decision::kPaired || a.decision[i] == Decision::kNew;
    if (has_landmark && i < a.landmark.size()) msg.landmark_id[i] = a.landmark[i];
  }
  msg.removed.assign(report.removed.begin(), report.removed.end());
  msg.association_time = report.association_s;
  msg.update_time = report.update_s;
  msg.nis = report.nis;
  msg.nis_dof = static_cast<std::uint32_t>(report.nis_dof);
  msg.lost = report.lost;
  msg.relocalised = report.relocalised;
  msg.landmarks = static_cast<std::uint32_t>(landmarks);
  return msg;
}

}  // namespace ekf_slam
