// Motion models: values against the closed-form equations, Jacobians against central
// differences, process noise, the straight-line limit of the twist model.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/motion_models.h"

namespace ekf_slam {
namespace test_motion_models {

constexpr double kStep = 1e-6;
constexpr double kTol = 1e-7;

// Central difference of a pose-valued f (yaw in row 2, wrapped) w.r.t. x.
template <int N, typename Fun>
Eigen::Matrix<double, 3, N> numericJacobian(Fun f, const Eigen::Matrix<double, N, 1>& x) {
  Eigen::Matrix<double, 3, N> J;
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> xp = x, xm = x;
    xp(k) += kStep;
    xm(k) -= kStep;
    Eigen::Vector3d d = f(xp) - f(xm);
    d(2) = wrapAngle(d(2));
    J.col(k) = d / (2.0 * kStep);
  }
  return J;
}

template <typename Model>
void checkJacobians(const Model& model, const Eigen::Vector3d& x, const typename Model::Input& u,
                    double dt) {
  Eigen::Matrix3d F;
  Eigen::Matrix<double, 3, Model::Input::RowsAtCompileTime> G;
  model.predict(x, u, dt, &F, &G);
  const Eigen::Matrix3d F_num =
      numericJacobian<3>([&](const Eigen::Vector3d& p) { return model.predict(p, u, dt); }, x);
  const auto G_num = numericJacobian<Model::Input::RowsAtCompileTime>(
      [&](const typename Model::Input& q) { return model.predict(x, q, dt); }, u);
  EXPECT_LT((F - F_num).norm(), kTol) << "F analytic\n" << F << "\nnumeric\n" << F_num;
  EXPECT_LT((G - G_num).norm(), kTol) << "G analytic\n" << G << "\nnumeric\n" << G_num;
}

void expectPoseNear(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double tol) {
  EXPECT_NEAR(a(0), b(0), tol);
  EXPECT_NEAR(a(1), b(1), tol);
  EXPECT_NEAR(wrapAngle(a(2) - b(2)), 0.0, tol);
}

// --- Ackermann ---------------------------------------------------------------------------------

TEST(AckermannModel, MatchesEquations) {
  AckermannParams p;
  p.a = 3.78;
  p.b = 0.5;
  const AckermannModel model(p);
  const double L = 2.83, H = 0.76, a = 3.78, b = 0.5;
  const double ve = 4.0, alpha = 0.2, dt = 0.025, phi = 1.1;
  const double vc = ve / (1 - std::tan(alpha) * H / L);
  EXPECT_NEAR(model.rearAxleSpeed(ve, alpha), vc, 1e-12);
  EXPECT_NEAR(model.yawRate(ve, alpha), vc / L * std::tan(alpha), 1e-12);
  const Eigen::Vector3d x(10, -5, phi);
  const Eigen::Vector3d y = model.predict(x, Eigen::Vector2d(ve, alpha), dt);
  const double ex = 10 + dt * (vc * std::cos(phi) -
                               vc / L * std::tan(alpha) * (a * std::sin(phi) + b * std::cos(phi)));
  const double ey = -5 + dt * (vc * std::sin(phi) +
                               vc / L * std::tan(alpha) * (a * std::cos(phi) - b * std::sin(phi)));
  EXPECT_NEAR(y(0), ex, 1e-12);
  EXPECT_NEAR(y(1), ey, 1e-12);
  EXPECT_NEAR(y(2), phi + dt * vc / L * std::tan(alpha), 1e-12);
}

TEST(AckermannModel, DefaultsAndStraightLine) {
  const AckermannModel model;
  EXPECT_DOUBLE_EQ(model.params().wheelbase, 2.83);
  EXPECT_DOUBLE_EQ(model.params().encoder_offset, 0.76);
  EXPECT_DOUBLE_EQ(model.params().a, 0.0);
  EXPECT_DOUBLE_EQ(model.params().b, 0.0);
  // No steering: straight along the heading at the encoder speed.
  const Eigen::Vector3d y =
      model.predict(Eigen::Vector3d(1, 1, M_PI / 2), Eigen::Vector2d(2, 0), 0.5);
  expectPoseNear(y, Eigen::Vector3d(1, 2, M_PI / 2), 1e-12);
}

TEST(AckermannModel, YawWrapped) {
  const AckermannModel model;
  const Eigen::Vector3d y =
      model.predict(Eigen::Vector3d(0, 0, M_PI - 0.01), Eigen::Vector2d(5, 0.4), 0.1);
  EXPECT_LE(y(2), M_PI);
  EXPECT_GT(y(2), -M_PI);
  EXPECT_LT(y(2), 0.0);  // crossed +pi
}

TEST(AckermannModel, JacobiansNumeric) {
  AckermannParams offset;
  offset.a = 3.78;
  offset.b = 0.5;
  AckermannParams odd;
  odd.wheelbase = 1.7;
  odd.encoder_offset = 0.3;
  odd.a = -1.2;
  odd.b = -0.8;
  for (const AckermannParams& p : {AckermannParams(), offset, odd}) {
    const AckermannModel model(p);
    checkJacobians(model, Eigen::Vector3d(1, 2, 0.3), Eigen::Vector2d(3.0, 0.25), 0.025);
    checkJacobians(model, Eigen::Vector3d(-4, 7, 3.1), Eigen::Vector2d(-1.5, -0.4), 0.2);
    checkJacobians(model, Eigen::Vector3d(0, 0, -2.0), Eigen::Vector2d(8.0, 0.0), 0.1);
  }
}

TEST(AckermannModel, ProcessNoise) {
  AckermannParams p;
  p.a = 1.0;
  p.additive = Eigen::Vector3d(0.1, 0.2, 0.3).asDiagonal();
  const AckermannModel model(p);
  const Eigen::Vector3d x(1, 2, 0.5);
  const Eigen::Vector2d u(3, 0.1);
  const double dt = 0.5;
  Eigen::Matrix3d F;
  Eigen::Matrix<double, 3, 2> G;
  const Eigen::Vector3d y = model.predict(x, u, dt, &F, &G);
  const MotionStep s = model.step(x, u, dt);
  EXPECT_EQ(s.pose, y);
  EXPECT_EQ(s.F, F);
  Eigen::Matrix2d N = Eigen::Vector2d(0.25, 0.0025).asDiagonal();
  const Eigen::Matrix3d Q = G * N * G.transpose() + dt * p.additive;
  EXPECT_LT((s.Q - Q).norm(), 1e-14);
  EXPECT_NEAR(s.Q(2, 2), (G(2, 0) * G(2, 0) * 0.25 + G(2, 1) * G(2, 1) * 0.0025) + 0.15, 1e-14);
}

// --- Twist -------------------------------------------------------------------------------------

TEST(TwistModel, ExactArc) {
  const TwistModel model;
  const double v = 2.0, w = 0.5, dt = 1.5, th = 0.7;
  const Eigen::Vector3d y = model.predict(Eigen::Vector3d(1, -1, th), Eigen::Vector2d(v, w), dt);
  expectPoseNear(y,
                 Eigen::Vector3d(1 + v / w * (std::sin(th + w * dt) - std::sin(th)),
                                 -1 + v / w * (std::cos(th) - std::cos(th + w * dt)), th + w * dt),
                 1e-12);
  // Half a circle of radius 1 starting at the origin facing +x ends at (0, 2) facing -x.
  const Eigen::Vector3d h =
      model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(M_PI, M_PI), 1.0);
  expectPoseNear(h, Eigen::Vector3d(0, 2, M_PI), 1e-12);
}

TEST(TwistModel, StraightLineLimit) {
  const TwistModel model;
  const Eigen::Vector3d x(3, 4, -0.6);
  const Eigen::Vector3d y0 = model.predict(x, Eigen::Vector2d(2, 0), 0.5);
  expectPoseNear(y0, Eigen::Vector3d(3 + std::cos(-0.6), 4 + std::sin(-0.6), -0.6), 1e-15);
  // Tiny rates, on both sides of the series threshold: continuous and close to the closed form.
  for (double w : {1e-12, 1e-8, 1e-5, 0.0199, 0.02, 0.0201, -0.0199, -0.0201}) {
    const Eigen::Vector3d y = model.predict(x, Eigen::Vector2d(2, w), 0.5);
    const double th = x(2), p = w * 0.5;
    const Eigen::Vector3d arc(3 + 2 / w * (std::sin(th + p) - std::sin(th)),
                              4 + 2 / w * (std::cos(th) - std::cos(th + p)), th + p);
    // The closed form itself loses about 1e-16 / w to cancellation: compare within that.
    expectPoseNear(y, arc, std::max(1e-13, 1e-14 / std::abs(w)));
    expectPoseNear(y, y0, 1.0 * std::abs(w));
  }
}

TEST(TwistModel, JacobiansNumeric) {
  const TwistModel model;
  for (double w : {0.0, 1e-9, -3e-4, 0.019, 0.021, 0.5, -2.0}) {
    checkJacobians(model, Eigen::Vector3d(1, 2, 0.3), Eigen::Vector2d(1.5, w), 0.5);
    checkJacobians(model, Eigen::Vector3d(-2, 0, 3.0), Eigen::Vector2d(-0.7, w), 1.0);
  }
}

TEST(TwistModel, JacobiansContinuousAtZeroRate) {
  const TwistModel model;
  const Eigen::Vector3d x(1, 2, 0.3);
  Eigen::Matrix3d F0, F1;
  Eigen::Matrix<double, 3, 2> G0, G1;
  model.predict(x, Eigen::Vector2d(1.5, 0.0), 0.5, &F0, &G0);
  model.predict(x, Eigen::Vector2d(1.5, 1e-7), 0.5, &F1, &G1);
  EXPECT_LT((F0 - F1).norm(), 1e-6);
  EXPECT_LT((G0 - G1).norm(), 1e-6);
  // Turning bends the path to the left: d x / d w at heading 0 points along +y.
  model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(2.0, 0.0), 1.0, &F0, &G0);
  EXPECT_NEAR(G0(0, 1), 0.0, 1e-15);
  EXPECT_NEAR(G0(1, 1), 2.0 * 1.0 * 1.0 / 2.0, 1e-15);  // v dt^2 / 2
}

TEST(TwistModel, ProcessNoise) {
  TwistParams p;
  p.additive = Eigen::Matrix3d::Identity() * 0.01;
  const TwistModel model(p);
  const Eigen::Vector3d x(0, 0, 0);
  const Eigen::Vector2d u(-2.0, 0.3);
  Eigen::Matrix3d F;
  Eigen::Matrix<double, 3, 2> G;
  model.predict(x, u, 0.2, &F, &G);
  const double sv = 0.1 + 0.05 * 2.0, sw = 0.02 + 0.01 * 2.0;
  const Eigen::Matrix3d Q =
      G * Eigen::Vector2d(sv * sv, sw * sw).asDiagonal() * G.transpose() + 0.2 * p.additive;
  EXPECT_LT((model.step(x, u, 0.2).Q - Q).norm(), 1e-15);
  EXPECT_NEAR(Q(2, 2), 0.2 * 0.2 * sw * sw + 0.002, 1e-15);
}

// twist_steering_wheelbase: the twist noise of speed and steering-angle noise on a car-like
// vehicle, (v, w) = (v, v tan(delta) / L): J diag(sigma_v^2, sigma_delta^2) J^T with the
// steering noise sigma_w_per_v L; on a straight the independent (v, w) noise of the default.
TEST(TwistModel, SteeringNoiseOnAWheelbase) {
  TwistParams p;
  p.sigma_v = 0.1;
  p.sigma_v_per_v = 0.0;
  p.sigma_w = 0.0;
  p.sigma_w_per_v = 0.01;
  const Eigen::Matrix2d straight = TwistModel(p).twistCovariance(Eigen::Vector2d(3.0, 0.0));
  p.steering_wheelbase = 4.0;
  const TwistModel model(p);
  EXPECT_LT((model.twistCovariance(Eigen::Vector2d(3.0, 0.0)) - straight).norm(), 1e-18);
  const double L = 4.0, v = 3.0, delta = 0.5, sd = p.sigma_w_per_v * L;
  const auto twist = [&](const Eigen::Vector2d& a) {  // (v, delta) -> (v, w), as a 3-vector
    return Eigen::Vector3d(a(0), a(0) * std::tan(a(1)) / L, 0.0);
  };
  const Eigen::Matrix<double, 3, 2> J = numericJacobian<2>(twist, Eigen::Vector2d(v, delta));
  const Eigen::Matrix2d expected =
      J.topRows<2>() * Eigen::Vector2d(0.01, sd * sd).asDiagonal() * J.topRows<2>().transpose();
  const Eigen::Matrix2d got = model.twistCovariance(twist(Eigen::Vector2d(v, delta)).head<2>());
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm()) << got << "\n" << expected;
  EXPECT_GT(got(0, 1), 0.0);  // a faster wheel turns faster at the same steering angle
  // The process noise uses it; odometry turning on the spot stays finite (angle capped).
  const Eigen::Matrix<double, 3, 2> G = [&] {
    Eigen::Matrix3d F;
    Eigen::Matrix<double, 3, 2> g;
    model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(v, 0.3), 0.1, &F, &g);
    return g;
  }();
  const Eigen::Matrix3d Q = model.step(Eigen::Vector3d::Zero(), Eigen::Vector2d(v, 0.3), 0.1).Q;
  EXPECT_LT((Q - G * model.twistCovariance(Eigen::Vector2d(v, 0.3)) * G.transpose()).norm(), 1e-18);
  EXPECT_TRUE(model.twistCovariance(Eigen::Vector2d(1e-12, 1.0)).allFinite());
  EXPECT_LT(model.twistCovariance(Eigen::Vector2d(1e-12, 1.0))(1, 1), 1.0);
}

// process_noise per_second: the pose covariance after one second of steps does not depend on the
// step rate (per_message: it shrinks with the rate); the yaw variance is sigma_w^2 * 1 s.
TEST(TwistModel, ProcessNoisePerSecondIsRateIndependent) {
  auto afterOneSecond = [](bool per_second, int rate) {
    TwistParams p;
    p.per_second = per_second;
    const TwistModel model(p);
    Eigen::Vector3d x(0, 0, 0);
    Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
    const Eigen::Vector2d u(1.5, 0.2);
    for (int k = 0; k < rate; ++k) {
      const MotionStep s = model.step(x, u, 1.0 / rate);
      P = s.F * P * s.F.transpose() + s.Q;
      x = s.pose;
    }
    return P;
  };
  const double sw = 0.02 + 0.01 * 1.5;
  const Eigen::Matrix3d slow = afterOneSecond(true, 10), fast = afterOneSecond(true, 100);
  EXPECT_NEAR(slow(2, 2), sw * sw, 1e-12);
  EXPECT_NEAR(fast(2, 2), sw * sw, 1e-12);
  EXPECT_LT((slow - fast).norm(), 0.02 * slow.norm());  // same up to the discretisation
  EXPECT_NEAR(afterOneSecond(false, 10)(2, 2), 10 * afterOneSecond(false, 100)(2, 2), 1e-12);
  // dt = 0: no noise, not NaN.
  TwistParams p;
  p.per_second = true;
  EXPECT_TRUE(TwistModel(p).step(Eigen::Vector3d::Zero(), Eigen::Vector2d(1, 0), 0.0).Q.isZero());
}

// --- Pose delta --------------------------------------------------------------------------------

TEST(PoseDeltaModel, ComposeAndBetween) {
  const PoseDeltaModel model;
  const Eigen::Vector3d y =
      model.predict(Eigen::Vector3d(1, 2, M_PI / 2), Eigen::Vector3d(3, 1, 0.5));
  expectPoseNear(y, Eigen::Vector3d(0, 5, M_PI / 2 + 0.5), 1e-12);
  const Eigen::Vector3d a(5, -3, 2.8), b(-1, 4, -2.9);
  const Eigen::Vector3d d = PoseDeltaModel::between(a, b);
  expectPoseNear(model.predict(a, d), b, 1e-12);
  EXPECT_NEAR(d(2), wrapAngle(-2.9 - 2.8), 1e-15);
  const Eigen::Vector3d u(0.3, -0.2, 0.1);
  const Eigen::Vector3d back = PoseDeltaModel::between(a, model.predict(a, u));
  EXPECT_LT((back - u).norm(), 1e-12);
}

TEST(PoseDeltaModel, JacobiansNumeric) {
  const PoseDeltaModel model;
  checkJacobians(model, Eigen::Vector3d(1, 2, 0.3), Eigen::Vector3d(0.5, -0.1, 0.05), 0.0);
  checkJacobians(model, Eigen::Vector3d(-7, 3, 3.1), Eigen::Vector3d(-1.0, 2.0, 0.2), 0.0);
  checkJacobians(model, Eigen::Vector3d(0, 0, -3.1), Eigen::Vector3d(0, 0, -0.2), 0.0);
}

TEST(PoseDeltaModel, ProcessNoise) {
  PoseDeltaParams p;
  p.additive = Eigen::Vector3d(1e-4, 2e-4, 3e-4).asDiagonal();
  const PoseDeltaModel model(p);
  // 5 m and 0.5 rad: sigma_t = 0.05*5 + 0.01*0.5 = 0.255; sigma_r = 0.05*0.5 + 0.01*5 = 0.075.
  const MotionStep s = model.step(Eigen::Vector3d(0, 0, 1.0), Eigen::Vector3d(3, 4, -0.5));
  EXPECT_NEAR(s.Q(0, 0), 0.255 * 0.255 + 1e-4, 1e-14);
  EXPECT_NEAR(s.Q(1, 1), 0.255 * 0.255 + 2e-4, 1e-14);
  EXPECT_NEAR(s.Q(2, 2), 0.075 * 0.075 + 3e-4, 1e-14);
  EXPECT_NEAR(s.Q(0, 1), 0.0, 1e-14);  // isotropic translation noise stays isotropic
  EXPECT_NEAR(s.Q(0, 2), 0.0, 1e-14);
  EXPECT_TRUE(model.step(Eigen::Vector3d(1, 1, 1), Eigen::Vector3d::Zero()).Q.isApprox(p.additive));
}

}  // namespace test_motion_models
}  // namespace ekf_slam
