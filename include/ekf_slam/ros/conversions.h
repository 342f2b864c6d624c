// Small bridges between ROS messages and the ROS-free pipeline types, shared by the node and the
// offline runner so both feed the pipeline identically.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Transform.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <Eigen/Core>
#include <boost/array.hpp>

#include "ekf_slam/AssociationStats.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"

namespace ekf_slam {

/// Planar (x, y, yaw) of a 3D pose / transform (yaw from the quaternion).
Eigen::Vector3d toPose2(const geometry_msgs::Pose& pose);
Eigen::Vector3d toPose2(const geometry_msgs::Transform& transform);
geometry_msgs::Pose toPoseMsg(const Eigen::Vector3d& pose);
/// Rotation by `yaw` about z.
geometry_msgs::Quaternion toQuaternionMsg(double yaw);
/// ROS's 6x6 (x, y, z, roll, pitch, yaw) covariance of a planar (x, y, yaw) one: P at rows and
/// columns 0, 1, 5; z, roll and pitch get `other_variance` on the diagonal; the rest is zero.
boost::array<double, 36> toCovarianceMsg(const Eigen::Matrix3d& P, double other_variance = 0.0);

/// Pose (x, y, yaw) of a sensor frame on `base_frame`, one rule for the node and the offline
/// runner: base_frame itself is the origin; an empty frame name, a missing transform or a
/// non-finite one throws tf2::TransformException (the message is then skipped and counted).
Eigen::Vector3d sensorOffset(const tf2::BufferCore& tf, const std::string& base_frame,
                             const std::string& frame);

/// nav_msgs/Odometry -> twist (v, w) and planar pose, stamped with header.stamp.
OdometryInput toOdometryInput(const nav_msgs::Odometry& msg);

/// Truth id of an observation that carries none (every negative id is a mover or clutter).
constexpr std::int64_t kNoTruthId = std::numeric_limits<std::int64_t>::min();

/// LandmarkObservationArray -> observations (R from the message's covariance, zeros when unset)
/// and the truth ids (kNoTruthId for observations without one; kept aside for scoring only).
std::vector<Observation> toObservations(const LandmarkObservationArray& msg,
                                        std::vector<std::int64_t>* truth_ids = nullptr);

/// Observation -> message entry.
LandmarkObservation toObservationMsg(const Observation& obs);

/// The map (id, mean, covariance, diameter, evidence, times observed).
LandmarkArray toLandmarkArray(const SlamPipeline& pipeline, const std::string& frame_id,
                              const ros::Time& stamp);

/// One scan's association report.
AssociationStats toAssociationStats(const ScanReport& report, const std::string& associator,
                                    std::size_t landmarks, const std::string& frame_id,
                                    const ros::Time& stamp);

}  // namespace ekf_slam
