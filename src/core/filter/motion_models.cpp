// Vehicle motion models: Ackermann (Victoria Park), twist (exact arc), pose delta.
#include "ekf_slam/core/filter/motion_models.h"

#include <algorithm>
#include <cmath>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

// --- Ackermann ---------------------------------------------------------------------------------

double AckermannModel::rearAxleSpeed(double v_e, double alpha) const {
  return v_e / (1.0 - std::tan(alpha) * p_.encoder_offset / p_.wheelbase);
}

double AckermannModel::yawRate(double v_e, double alpha) const {
  return rearAxleSpeed(v_e, alpha) * std::tan(alpha) / p_.wheelbase;
}

Eigen::Vector3d AckermannModel::predict(const Eigen::Vector3d& x, const Input& u, double dt,
                                        Eigen::Matrix3d* F, Eigen::Matrix<double, 3, 2>* G) const {
  const double L = p_.wheelbase;
  const double t = std::tan(u(1));
  const double k = 1.0 / (1.0 - t * p_.encoder_offset / L);  // dv_c / dv_e
  const double vc = u(0) * k;
  const double w = vc * t / L;  // yaw rate
  const double c = std::cos(x(2));
  const double s = std::sin(x(2));
  // Velocity of the tracked point (a, b): rear-axle velocity plus w x (a, b) in the world.
  const double ab_x = p_.a * s + p_.b * c;
  const double ab_y = p_.a * c - p_.b * s;
  const double xd = vc * c - w * ab_x;
  const double yd = vc * s + w * ab_y;

  if (F) {
    *F << 1.0, 0.0, dt * (-vc * s - w * ab_y), 0.0, 1.0, dt * (vc * c - w * ab_x), 0.0, 0.0, 1.0;
  }
  if (G) {
    const double sec2 = 1.0 + t * t;
    const double dvc_dalpha = u(0) * k * k * (p_.encoder_offset / L) * sec2;
    const double dw_dve = k * t / L;
    const double dw_dalpha = (dvc_dalpha * t + vc * sec2) / L;
    *G << dt * (k * c - dw_dve * ab_x), dt * (dvc_dalpha * c - dw_dalpha * ab_x),
        dt * (k * s + dw_dve * ab_y), dt * (dvc_dalpha * s + dw_dalpha * ab_y), dt * dw_dve,
        dt * dw_dalpha;
  }
  return Eigen::Vector3d(x(0) + dt * xd, x(1) + dt * yd, wrapAngle(x(2) + dt * w));
}

MotionStep AckermannModel::step(const Eigen::Vector3d& x, const Input& u, double dt) const {
  MotionStep out;
  Eigen::Matrix<double, 3, 2> G;
  out.pose = predict(x, u, dt, &out.F, &G);
  const Eigen::Vector2d n(p_.sigma_speed * p_.sigma_speed, p_.sigma_steering * p_.sigma_steering);
  out.Q.noalias() = G * n.asDiagonal() * G.transpose();
  out.Q_translation.noalias() = n(0) * G.col(0) * G.col(0).transpose();
  out.Q_rotation.noalias() = n(1) * G.col(1) * G.col(1).transpose();
  out.Q += p_.additive * dt;
  return out;
}

// --- Twist -------------------------------------------------------------------------------------

namespace {

// s1 = sin(p) / p, c1 = (1 - cos(p)) / p and their derivatives. The arc displacement is
// v dt (cos th s1 - sin th c1, sin th s1 + cos th c1); a Taylor series near p = 0 keeps the value
// and the Jacobians smooth through the straight-line limit (the closed form cancels badly there).
struct ArcCoefficients {
  double s1, c1, ds1, dc1;
};

ArcCoefficients arcCoefficients(double p) {
  ArcCoefficients a;
  if (std::abs(p) < 1e-2) {
    // Truncation error below 1e-16 for |p| < 1e-2.
    const double p2 = p * p;
    a.s1 = 1.0 - p2 / 6.0 * (1.0 - p2 / 20.0 * (1.0 - p2 / 42.0));
    a.c1 = p / 2.0 * (1.0 - p2 / 12.0 * (1.0 - p2 / 30.0 * (1.0 - p2 / 56.0)));
    a.ds1 = -p / 3.0 * (1.0 - p2 / 10.0 * (1.0 - p2 / 28.0 * (1.0 - p2 / 54.0)));
    a.dc1 = 0.5 - p2 / 8.0 * (1.0 - p2 / 18.0 * (1.0 - p2 / 40.0 * (1.0 - p2 / 70.0)));
  } else {
    const double s = std::sin(p);
    const double c = std::cos(p);
    a.s1 = s / p;
    a.c1 = (1.0 - c) / p;
    a.ds1 = (p * c - s) / (p * p);
    a.dc1 = (p * s - 1.0 + c) / (p * p);
  }
  return a;
}

}  // namespace

Eigen::Vector3d TwistModel::predict(const Eigen::Vector3d& x, const Input& u, double dt,
                                    Eigen::Matrix3d* F, Eigen::Matrix<double, 3, 2>* G) const {
  const double v = u(0);
  const double p = u(1) * dt;  // heading change over the step
  const ArcCoefficients a = arcCoefficients(p);
  const double c = std::cos(x(2));
  const double s = std::sin(x(2));
  const double fx = c * a.s1 - s * a.c1;  // unit-speed displacement per second
  const double fy = s * a.s1 + c * a.c1;
  const double ddx = v * dt * fx;
  const double ddy = v * dt * fy;
  if (F) *F << 1.0, 0.0, -ddy, 0.0, 1.0, ddx, 0.0, 0.0, 1.0;
  if (G) {
    const double k = v * dt * dt;  // d(displacement)/dw = v dt * dp/dw * d(f)/dp
    *G << dt * fx, k * (c * a.ds1 - s * a.dc1), dt * fy, k * (s * a.ds1 + c * a.dc1), 0.0, dt;
  }
  return Eigen::Vector3d(x(0) + ddx, x(1) + ddy, wrapAngle(x(2) + p));
}

MotionStep TwistModel::step(const Eigen::Vector3d& x, const Input& u, double dt,
                            Eigen::Matrix<double, 3, 2>* G_out) const {
  MotionStep out;
  Eigen::Matrix<double, 3, 2> G;
  out.pose = predict(x, u, dt, &out.F, &G);
  if (G_out) *G_out = G;
  Eigen::Matrix2d n = twistCovariance(u);
  // White twist noise of density sigma^2 averaged over dt has variance sigma^2 / dt; G grows
  // with dt, so Q grows with dt (at dt = 0, G = 0: no noise rather than 0 * inf).
  if (p_.per_second) n = dt > 0.0 ? Eigen::Matrix2d(n / dt) : Eigen::Matrix2d::Zero();
  out.Q.noalias() = G * n * G.transpose();
  Eigen::Matrix2d speed, turn;
  twistCovarianceTerms(u, &speed, &turn);
  const double per_dt = p_.per_second ? (dt > 0.0 ? 1.0 / dt : 0.0) : 1.0;
  out.Q_translation.noalias() = per_dt * G * speed * G.transpose();
  out.Q_rotation.noalias() = per_dt * G * turn * G.transpose();
  out.Q += p_.additive * dt;
  return out;
}

namespace {
constexpr double kMaxTanSteering = 10.0;
}  // namespace

Eigen::Matrix2d TwistModel::twistCovariance(const Input& u) const {
  const double av = std::abs(u(0));
  const double sv = p_.sigma_v + p_.sigma_v_per_v * av;
  double sw = p_.sigma_w + p_.sigma_w_per_v * av;
  Eigen::Matrix2d n = Eigen::Vector2d(sv * sv, sw * sw).asDiagonal();
  const double L = p_.steering_wheelbase;
  if (L > 0.0 && av > 0.0) {
    // w = v tan(delta) / L: dw = (w / v) dv + v (1 + tan^2 delta) / L ddelta, with the steering
    // noise sigma_w_per_v L; at w = 0 this is the diagonal above.
    // Curvature tan(delta) / L, the steering angle capped at atan(10) = 84 deg: odometry that
    // turns almost on the spot is no car's, and its w / v would blow the noise up.
    const double k = std::clamp(u(1) / u(0), -kMaxTanSteering / L, kMaxTanSteering / L);
    sw = p_.sigma_w + p_.sigma_w_per_v * av * (1.0 + L * L * k * k);
    n << sv * sv, k * sv * sv, k * sv * sv, sw * sw + k * k * sv * sv;
  }
  return n;
}

void TwistModel::twistCovarianceTerms(const Input& u, Eigen::Matrix2d* speed,
                                      Eigen::Matrix2d* turn) const {
  // The same terms as twistCovariance(), kept apart.
  const double av = std::abs(u(0));
  const double sv = p_.sigma_v + p_.sigma_v_per_v * av;
  double sw = p_.sigma_w + p_.sigma_w_per_v * av;
  *speed << sv * sv, 0.0, 0.0, 0.0;
  const double L = p_.steering_wheelbase;
  if (L > 0.0 && av > 0.0) {
    const double k = std::clamp(u(1) / u(0), -kMaxTanSteering / L, kMaxTanSteering / L);
    sw = p_.sigma_w + p_.sigma_w_per_v * av * (1.0 + L * L * k * k);
    *speed << sv * sv, k * sv * sv, k * sv * sv, k * k * sv * sv;
  }
  *turn << 0.0, 0.0, 0.0, sw * sw;
}

// --- Pose delta --------------------------------------------------------------------------------

Eigen::Vector3d PoseDeltaModel::predict(const Eigen::Vector3d& x, const Input& u, double /*dt*/,
                                        Eigen::Matrix3d* F, Eigen::Matrix3d* G) const {
  const double c = std::cos(x(2));
  const double s = std::sin(x(2));
  const double wx = c * u(0) - s * u(1);  // delta in the world frame
  const double wy = s * u(0) + c * u(1);
  if (F) *F << 1.0, 0.0, -wy, 0.0, 1.0, wx, 0.0, 0.0, 1.0;
  if (G) *G << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return Eigen::Vector3d(x(0) + wx, x(1) + wy, wrapAngle(x(2) + u(2)));
}

MotionStep PoseDeltaModel::step(const Eigen::Vector3d& x, const Input& u, double dt) const {
  MotionStep out;
  Eigen::Matrix3d G;
  out.pose = predict(x, u, dt, &out.F, &G);
  const double trans = std::hypot(u(0), u(1));
  const double rot = std::abs(u(2));
  const double st = p_.alpha_trans_per_trans * trans + p_.alpha_trans_per_rot * rot;
  const double sr = p_.alpha_rot_per_rot * rot + p_.alpha_rot_per_trans * trans;
  const Eigen::Vector3d n(st * st, st * st, sr * sr);
  out.Q.noalias() = G * n.asDiagonal() * G.transpose();
  out.Q_translation.noalias() = st * st * G.leftCols<2>() * G.leftCols<2>().transpose();
  out.Q_rotation.noalias() = sr * sr * G.col(2) * G.col(2).transpose();
  out.Q += p_.additive;
  return out;
}

PoseDeltaModel::Input PoseDeltaModel::between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = std::cos(a(2));
  const double s = std::sin(a(2));
  const double dx = b(0) - a(0);
  const double dy = b(1) - a(1);
  return Input(c * dx + s * dy, -s * dx + c * dy, wrapAngle(b(2) - a(2)));
}

}  // namespace ekf_slam
