// Observation of a 2D point landmark by a sensor mounted on the vehicle: range-bearing (a laser's
// trees) or Cartesian (x, y) in the sensor frame (a camera reading floor markers, a radar), each
// with its own prediction, Jacobians and inverse. ROS-free (Eigen only).
#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace ekf_slam {

using Matrix23d = Eigen::Matrix<double, 2, 3>;

/// What an observation's z holds; its covariance R is in the same coordinates.
enum class MeasurementKind : std::uint8_t {
  kRangeBearing = 0,  ///< (range, bearing) [m, rad]
  kCartesian = 1,     ///< (x, y) in the sensor frame [m]
};

/// z = (range, bearing) of landmark m seen from a sensor at `sensor_offset` (x, y, yaw in the
/// vehicle frame) on a vehicle at pose xv = (x, y, yaw). Bearing is measured from the sensor's
/// x axis, counter-clockwise positive (sensor_msgs/LaserScan convention), wrapped to (-pi, pi].
class RangeBearingModel {
 public:
  explicit RangeBearingModel(const Eigen::Vector3d& sensor_offset = Eigen::Vector3d::Zero())
      : offset_(sensor_offset) {}

  void setSensorOffset(const Eigen::Vector3d& offset) { offset_ = offset; }
  const Eigen::Vector3d& sensorOffset() const { return offset_; }

  /// Sensor pose in the world frame for vehicle pose xv.
  Eigen::Vector3d sensorPose(const Eigen::Vector3d& xv) const;

  /// Predicted observation h(xv, m); optional Jacobians w.r.t. the vehicle pose (2x3) and the
  /// landmark (2x2).
  Eigen::Vector2d predict(const Eigen::Vector3d& xv, const Eigen::Vector2d& m,
                          Matrix23d* H_pose = nullptr, Eigen::Matrix2d* H_landmark = nullptr) const;

  /// Inverse model g(xv, z): landmark position; optional Jacobians w.r.t. the vehicle pose (2x3)
  /// and the observation (2x2).
  Eigen::Vector2d inverse(const Eigen::Vector3d& xv, const Eigen::Vector2d& z,
                          Matrix23d* G_pose = nullptr, Eigen::Matrix2d* G_obs = nullptr) const;

  /// z - z_hat with the bearing wrapped to (-pi, pi].
  static Eigen::Vector2d innovation(const Eigen::Vector2d& z, const Eigen::Vector2d& z_hat);

  // --- either measurement kind (range-bearing: the functions above) ---------------------------
  /// Cartesian: z = Rot(-yaw_s) (m - s), s the sensor position.
  Eigen::Vector2d predict(const Eigen::Vector3d& xv, const Eigen::Vector2d& m, MeasurementKind kind,
                          Matrix23d* H_pose = nullptr, Eigen::Matrix2d* H_landmark = nullptr) const;
  Eigen::Vector2d inverse(const Eigen::Vector3d& xv, const Eigen::Vector2d& z, MeasurementKind kind,
                          Matrix23d* G_pose = nullptr, Eigen::Matrix2d* G_obs = nullptr) const;
  /// z - z_hat; only a bearing is wrapped.
  static Eigen::Vector2d innovation(const Eigen::Vector2d& z, const Eigen::Vector2d& z_hat,
                                    MeasurementKind kind);
  /// The point z reports in the sensor frame, and optionally J = d point / d z (identity for a
  /// Cartesian z): point covariance J R J^T.
  static Eigen::Vector2d sensorPoint(const Eigen::Vector2d& z, MeasurementKind kind,
                                     Eigen::Matrix2d* J = nullptr);
  /// Distance from the sensor that z reports.
  static double range(const Eigen::Vector2d& z, MeasurementKind kind);

  // --- second-order terms (EKF2, docs/consistency.md) -----------------------------------------
  /// Covariance of the landmark's position relative to the sensor, d = m - s (world frame), from
  /// the pose covariance Pvv (3x3), the landmark-pose cross-covariance Pmv (2x3) and the
  /// landmark's Pmm (2x2), to first order.
  Eigen::Matrix2d relativeCovariance(const Eigen::Vector3d& xv, const Eigen::Matrix3d& Pvv,
                                     const Matrix23d& Pmv, const Eigen::Matrix2d& Pmm) const;
  /// What the second-order terms of (range, bearing) = h(d) add to the first-order prediction
  /// when d = m - s is uncertain with covariance C: `mean` to add to h(d) (E[h] - h(E[d])) and
  /// `cov` to add to R (the variance of the quadratic terms). Why: a landmark far away and known
  /// only across the line of sight (lateral sd sigma at range r) lies farther on average than
  /// its mean (by sigma^2 / 2r) and with sigma^2 / (sqrt(2) r) of range spread the first-order
  /// prediction does not see; with a precise range sensor that is several sd of its noise.
  static void rangeBearingSecondOrder(const Eigen::Vector2d& d, const Eigen::Matrix2d& C,
                                      Eigen::Vector2d* mean, Eigen::Matrix2d* cov);
  /// The same for the inverse: a point at `range` along the world direction `direction`, with
  /// covariance `C` of (range, direction): the second-order `mean` (world frame) to add to the
  /// first-order point and `cov` to add to its first-order covariance (the banana of a far
  /// return seen with bearing noise, mean pulled inwards by range sigma_phi^2 / 2).
  static void polarSecondOrder(double range, double direction, const Eigen::Matrix2d& C,
                               Eigen::Vector2d* mean, Eigen::Matrix2d* cov);

 private:
  Eigen::Vector3d offset_;
};

}  // namespace ekf_slam
