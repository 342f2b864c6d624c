// Range-bearing and Cartesian observation models with a sensor offset on the vehicle.
#include "ekf_slam/core/filter/observation_model.h"

#include <cmath>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

namespace {

// The sensor's lever arm (lx, ly) in the world frame and the cos / sin of its world yaw.
struct SensorFrame {
  double lx, ly, cs, ss;
};

SensorFrame sensorFrame(const Eigen::Vector3d& xv, const Eigen::Vector3d& offset) {
  const double c = std::cos(xv(2));
  const double s = std::sin(xv(2));
  const double ys = xv(2) + offset(2);
  return {c * offset(0) - s * offset(1), s * offset(0) + c * offset(1), std::cos(ys), std::sin(ys)};
}

}  // namespace

Eigen::Vector3d RangeBearingModel::sensorPose(const Eigen::Vector3d& xv) const {
  const double c = std::cos(xv(2));
  const double s = std::sin(xv(2));
  return Eigen::Vector3d(xv(0) + c * offset_(0) - s * offset_(1),
                         xv(1) + s * offset_(0) + c * offset_(1), wrapAngle(xv(2) + offset_(2)));
}

Eigen::Vector2d RangeBearingModel::predict(const Eigen::Vector3d& xv, const Eigen::Vector2d& m,
                                           Matrix23d* H_pose, Eigen::Matrix2d* H_landmark) const {
  const double c = std::cos(xv(2));
  const double s = std::sin(xv(2));
  // Sensor position and its derivative w.r.t. the vehicle yaw (the lever arm rotated by 90 deg).
  const double lx = c * offset_(0) - s * offset_(1);
  const double ly = s * offset_(0) + c * offset_(1);
  const double dx = m(0) - (xv(0) + lx);
  const double dy = m(1) - (xv(1) + ly);
  const double q = dx * dx + dy * dy;
  const double r = std::sqrt(q);
  const Eigen::Vector2d z(r, wrapAngle(std::atan2(dy, dx) - xv(2) - offset_(2)));

  if (H_pose || H_landmark) {
    // dz/dm; at r = 0 this is inf/NaN, which the EKF detects and rejects.
    const double a = dx / r, b = dy / r;
    const double e = -dy / q, f = dx / q;
    if (H_landmark) *H_landmark << a, b, e, f;
    if (H_pose) {
      // The sensor position moves with the pose as (1, 0, -ly), (0, 1, lx); the bearing also loses
      // the yaw directly.
      *H_pose << -a, -b, a * ly - b * lx, -e, -f, e * ly - f * lx - 1.0;
    }
  }
  return z;
}

Eigen::Vector2d RangeBearingModel::inverse(const Eigen::Vector3d& xv, const Eigen::Vector2d& z,
                                           Matrix23d* G_pose, Eigen::Matrix2d* G_obs) const {
  const double c = std::cos(xv(2));
  const double s = std::sin(xv(2));
  const double lx = c * offset_(0) - s * offset_(1);
  const double ly = s * offset_(0) + c * offset_(1);
  const double t = xv(2) + offset_(2) + z(1);  // world direction of the beam
  const double ct = std::cos(t);
  const double st = std::sin(t);
  const double r = z(0);
  if (G_pose) *G_pose << 1.0, 0.0, -ly - r * st, 0.0, 1.0, lx + r * ct;
  if (G_obs) *G_obs << ct, -r * st, st, r * ct;
  return Eigen::Vector2d(xv(0) + lx + r * ct, xv(1) + ly + r * st);
}

Eigen::Vector2d RangeBearingModel::innovation(const Eigen::Vector2d& z,
                                              const Eigen::Vector2d& z_hat) {
  return Eigen::Vector2d(z(0) - z_hat(0), wrapAngle(z(1) - z_hat(1)));
}

Eigen::Vector2d RangeBearingModel::predict(const Eigen::Vector3d& xv, const Eigen::Vector2d& m,
                                           MeasurementKind kind, Matrix23d* H_pose,
                                           Eigen::Matrix2d* H_landmark) const {
  if (kind == MeasurementKind::kRangeBearing) return predict(xv, m, H_pose, H_landmark);
  const SensorFrame f = sensorFrame(xv, offset_);
  const double lx = f.lx, ly = f.ly, cs = f.cs, ss = f.ss;
  const double dx = m(0) - (xv(0) + lx);
  const double dy = m(1) - (xv(1) + ly);
  const Eigen::Vector2d z(cs * dx + ss * dy, -ss * dx + cs * dy);
  if (H_landmark) *H_landmark << cs, ss, -ss, cs;
  if (H_pose) {
    // d/dyaw: the sensor position moves by (-ly, lx) and the frame turns: d z = (z_y, -z_x).
    *H_pose << -cs, -ss, cs * ly - ss * lx + z(1), ss, -cs, -ss * ly - cs * lx - z(0);
  }
  return z;
}

Eigen::Vector2d RangeBearingModel::inverse(const Eigen::Vector3d& xv, const Eigen::Vector2d& z,
                                           MeasurementKind kind, Matrix23d* G_pose,
                                           Eigen::Matrix2d* G_obs) const {
  if (kind == MeasurementKind::kRangeBearing) return inverse(xv, z, G_pose, G_obs);
  const SensorFrame f = sensorFrame(xv, offset_);
  const double lx = f.lx, ly = f.ly, cs = f.cs, ss = f.ss;
  const double wx = cs * z(0) - ss * z(1);  // z rotated into the world frame
  const double wy = ss * z(0) + cs * z(1);
  if (G_pose) *G_pose << 1.0, 0.0, -ly - wy, 0.0, 1.0, lx + wx;
  if (G_obs) *G_obs << cs, -ss, ss, cs;
  return Eigen::Vector2d(xv(0) + lx + wx, xv(1) + ly + wy);
}

Eigen::Vector2d RangeBearingModel::innovation(const Eigen::Vector2d& z,
                                              const Eigen::Vector2d& z_hat, MeasurementKind kind) {
  return kind == MeasurementKind::kRangeBearing ? innovation(z, z_hat) : Eigen::Vector2d(z - z_hat);
}

Eigen::Vector2d RangeBearingModel::sensorPoint(const Eigen::Vector2d& z, MeasurementKind kind,
                                               Eigen::Matrix2d* J) {
  if (kind == MeasurementKind::kCartesian) {
    if (J) J->setIdentity();
    return z;
  }
  const double c = std::cos(z(1));
  const double s = std::sin(z(1));
  if (J) *J << c, -z(0) * s, s, z(0) * c;
  return Eigen::Vector2d(z(0) * c, z(0) * s);
}

double RangeBearingModel::range(const Eigen::Vector2d& z, MeasurementKind kind) {
  return kind == MeasurementKind::kRangeBearing ? z(0) : z.norm();
}

Eigen::Matrix2d RangeBearingModel::relativeCovariance(const Eigen::Vector3d& xv,
                                                      const Eigen::Matrix3d& Pvv,
                                                      const Matrix23d& Pmv,
                                                      const Eigen::Matrix2d& Pmm) const {
  const SensorFrame f = sensorFrame(xv, offset_);
  Matrix23d Js;  // d s / d xv: the sensor position moves with the pose and its lever arm
  Js << 1.0, 0.0, -f.ly, 0.0, 1.0, f.lx;
  const Eigen::Matrix2d cross = Pmv * Js.transpose();
  Eigen::Matrix2d C = Pmm - cross - cross.transpose() + Js * Pvv * Js.transpose();
  return 0.5 * (C + C.transpose());
}

void RangeBearingModel::rangeBearingSecondOrder(const Eigen::Vector2d& d, const Eigen::Matrix2d& C,
                                                Eigen::Vector2d* mean, Eigen::Matrix2d* cov) {
  // In the line-of-sight frame (a radial, b lateral): range = |(r + a, b)|, bearing =
  // atan2(b, r + a) + const. Their Hessians at (0, 0): range [[0, 0], [0, 1/r]], bearing
  // [[0, -1/r^2], [-1/r^2, 0]]; mean 1/2 tr(H C), covariance 1/2 tr(H_i C H_j C).
  const double r = d.norm();
  const Eigen::Vector2d u = d / r;
  const Eigen::Vector2d w(-u(1), u(0));
  const double caa = u.dot(C * u), cbb = w.dot(C * w), cab = u.dot(C * w);
  const double r2 = r * r;
  *mean << cbb / (2.0 * r), -cab / r2;
  const double cov_rb = -cab * cbb / (r2 * r);
  *cov << cbb * cbb / (2.0 * r2), cov_rb, cov_rb, (cab * cab + caa * cbb) / (r2 * r2);
}

void RangeBearingModel::polarSecondOrder(double range, double direction, const Eigen::Matrix2d& C,
                                         Eigen::Vector2d* mean, Eigen::Matrix2d* cov) {
  // p = range (cos, sin)(direction): along u the Hessian is [[0, 0], [0, -range]], along w
  // [[0, 1], [1, 0]] (w.r.t. range, direction).
  const Eigen::Vector2d u(std::cos(direction), std::sin(direction));
  const Eigen::Vector2d w(-u(1), u(0));
  const double srr = C(0, 0), spp = C(1, 1), srp = C(0, 1);
  const double m_u = -0.5 * range * spp, m_w = srp;
  const double c_uu = 0.5 * range * range * spp * spp;
  const double c_ww = srr * spp + srp * srp;
  const double c_uw = -range * srp * spp;
  *mean = m_u * u + m_w * w;
  *cov = c_uu * u * u.transpose() + c_ww * w * w.transpose() +
         c_uw * (u * w.transpose() + w * u.transpose());
}

}  // namespace ekf_slam
