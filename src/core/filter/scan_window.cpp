#include "ekf_slam/core/filter/scan_window.h"

#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

void carryPoint(const Eigen::Vector3d& origin, const Eigen::Matrix3d& origin_covariance,
                Eigen::Vector2d* point, Eigen::Matrix2d* covariance) {
  const Eigen::Matrix2d R = rotation2d(origin.z());
  const Eigen::Vector2d rotated = R * *point;
  // d(R p + t) / d(t, theta) = [I, R' p], R' p = (-y, x) of R p.
  Eigen::Matrix<double, 2, 3> J;
  J << 1.0, 0.0, -rotated.y(), 0.0, 1.0, rotated.x();
  *point = rotated + origin.head<2>();
  *covariance = R * *covariance * R.transpose() + J * origin_covariance * J.transpose();
}

void ScanWindow::addMotion(const Eigen::Matrix3d& F, const Eigen::Matrix3d& Q) {
  for (Entry& e : scans_) e.Q = F * e.Q * F.transpose() + Q;
}

void ScanWindow::push(std::uint32_t scan, const Eigen::Vector3d& pose,
                      const std::vector<Observation>& observations) {
  if (observations.empty() || size_ <= 0) return;
  scans_.push_back(Entry{scan, pose, Eigen::Matrix3d::Zero(), observations});
  while (static_cast<int>(scans_.size()) > size_) scans_.pop_front();
}

std::vector<CarriedScan> ScanWindow::carried(const Eigen::Vector3d& now) const {
  std::vector<CarriedScan> out;
  const Eigen::Matrix2d Rt = rotation2d(now.z()).transpose();
  for (const Entry& e : scans_) {
    CarriedScan c;
    c.scan = e.scan;
    c.observations = e.observations;
    // origin = now^-1 o pose_e. Its uncertainty is the current pose's given this one's, Q:
    // d origin / d now = [-R^T, -S origin_xy; 0 0 -1] with S the 90 degree turn.
    c.origin = composePose(inversePose(now), e.pose);
    Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
    J.topLeftCorner<2, 2>() = -Rt;
    J(0, 2) = c.origin.y();
    J(1, 2) = -c.origin.x();
    J(2, 2) = -1.0;
    c.origin_covariance = J * e.Q * J.transpose();
    c.pose = e.pose;
    c.Q = e.Q;
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace ekf_slam
