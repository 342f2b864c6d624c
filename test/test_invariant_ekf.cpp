// EkfSlam with Linearisation::kInvariant (the right-invariant EKF, docs/consistency.md). The
// filter keeps P in the standard coordinates and re-expresses it after each update; these tests
// redo the update in the invariant coordinates themselves, with explicit matrices, and check the
// property the filter is chosen for: an update adds no information on the global rotation.
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"

namespace ekf_slam {
namespace test_invariant_ekf {

constexpr double kStep = 1e-6;
const RangeBearingModel kModel(Eigen::Vector3d(0.4, -0.1, 0.05));  // a sensor off the centre

Eigen::Vector2d perp(const Eigen::Vector2d& p) { return Eigen::Vector2d(-p(1), p(0)); }

// A filter with two correction states, three landmarks and two clones taken at different poses,
// all correlated by a prediction and an update in between.
EkfSlam makeFilter(Linearisation lin) {
  EkfSlam ekf;
  ekf.setLinearisation(lin);
  CorrectionPrior c;
  c.dim = 2;
  c.mean = Eigen::Vector2d(1.0, 0.0);
  c.sigma = Eigen::Vector2d(0.05, 0.02);
  c.lower = Eigen::Vector2d(0.5, -1.0);
  c.upper = Eigen::Vector2d(1.5, 1.0);
  ekf.reset(Eigen::Vector3d(3.0, -2.0, 0.4), Eigen::Vector3d(0.3, 0.2, 0.05).asDiagonal(), c);
  const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.002).asDiagonal();
  ekf.addLandmark(Eigen::Vector2d(8.0, 0.3), R, kModel);
  ekf.addLandmark(Eigen::Vector2d(12.0, -0.6), R, kModel);
  ekf.addClone(1.0);
  MotionStep step = TwistModel().step(ekf.pose(), Eigen::Vector2d(2.0, 0.3), 0.5);
  step.corrections = 2;
  step.Fc = Eigen::Matrix<double, 3, 2>::Zero();
  step.Fc(0, 0) = 0.3;
  step.Fc(2, 1) = 0.2;
  step.Qvc.setZero();
  step.Qc = Eigen::Vector2d(1e-4, 1e-4).asDiagonal();
  EXPECT_TRUE(ekf.predict(step));
  ekf.addLandmark(Eigen::Vector2d(6.0, 1.1), R, kModel);
  ekf.addClone(2.0);
  EXPECT_TRUE(ekf.predict(step));
  std::vector<Pairing> p(2);
  for (int i = 0; i < 2; ++i) {
    p[i].id = ekf.landmarkIds()[i];
    p[i].R = R;
    p[i].z = kModel.predict(ekf.pose(), ekf.landmark(i), MeasurementKind::kRangeBearing) +
             Eigen::Vector2d(0.3, 0.04);
  }
  EXPECT_TRUE(ekf.update(p, kModel));
  return ekf;
}

// The pairings of the update under test: one from the current pose, one from each clone.
std::vector<Pairing> testPairings(const EkfSlam& ekf) {
  std::vector<Pairing> p;
  const Eigen::Matrix2d R = Eigen::Vector2d(0.02, 0.001).asDiagonal();
  const std::vector<std::pair<int, CloneId>> seen = {
      {0, kNoClone}, {1, ekf.cloneIds()[0]}, {2, ekf.cloneIds()[1]}};
  for (const auto& [index, clone] : seen) {
    Pairing q;
    q.id = ekf.landmarkIds()[index];
    q.clone = clone;
    q.R = R;
    const Eigen::Vector3d from = clone == kNoClone ? ekf.pose() : ekf.clonePose(clone);
    q.z = kModel.predict(from, ekf.landmark(index), MeasurementKind::kRangeBearing) +
          Eigen::Vector2d(-0.4, 0.06);
    p.push_back(q);
  }
  return p;
}

// T(x): standard error = T invariant error. Each heading's column carries J p over the positions
// that turn with it: the pose's over the pose and the landmarks, a clone's over the clone.
Eigen::MatrixXd invariantFrame(const EkfSlam& ekf) {
  const Eigen::VectorXd& x = ekf.mean();
  const Eigen::Index n = x.size();
  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n);
  T.block<2, 1>(0, 2) = perp(x.head<2>());
  for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
    const int r = ekf.stateRow(static_cast<int>(k));
    T.block<2, 1>(r, 2) = perp(x.segment<2>(r));
  }
  for (const CloneId c : ekf.cloneIds()) {
    const int r = ekf.cloneRow(c);
    T.block<2, 1>(r, r + 2) = perp(x.segment<2>(r));
  }
  return T;
}

// The direction of a global rotation about the origin at the estimate: every heading turns and
// every position moves by J p (the correction states do not move).
Eigen::VectorXd rotationDirection(const EkfSlam& ekf) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(ekf.mean().size());
  u(2) = 1.0;
  for (const CloneId c : ekf.cloneIds()) u(ekf.cloneRow(c) + 2) = 1.0;
  return invariantFrame(ekf) * u;  // T maps the invariant direction (headings only) onto it
}

// H (rows of all pairings) by central differences of h at the current estimate.
Eigen::MatrixXd numericH(const EkfSlam& ekf, const std::vector<Pairing>& pairings) {
  const Eigen::VectorXd x = ekf.mean();
  const Eigen::Index n = x.size();
  Eigen::MatrixXd H(2 * pairings.size(), n);
  for (std::size_t i = 0; i < pairings.size(); ++i) {
    const int lr = ekf.stateRow(ekf.indexOf(pairings[i].id));
    const int pr = pairings[i].clone == kNoClone ? 0 : ekf.cloneRow(pairings[i].clone);
    for (Eigen::Index j = 0; j < n; ++j) {
      Eigen::VectorXd a = x, b = x;
      a(j) += kStep;
      b(j) -= kStep;
      const Eigen::Vector2d za =
          kModel.predict(a.segment<3>(pr), a.segment<2>(lr), MeasurementKind::kRangeBearing);
      const Eigen::Vector2d zb =
          kModel.predict(b.segment<3>(pr), b.segment<2>(lr), MeasurementKind::kRangeBearing);
      H.block<2, 1>(2 * i, j) =
          RangeBearingModel::innovation(za, zb, MeasurementKind::kRangeBearing) / (2.0 * kStep);
    }
  }
  return H;
}

// x moved by exp(xi): positions p <- R(phi) p + V(phi) u with phi the heading they turn with.
Eigen::VectorXd exponential(const EkfSlam& ekf, const Eigen::VectorXd& xi) {
  Eigen::VectorXd x = ekf.mean();
  const auto move = [&](double phi, int r) {
    const double a = std::sin(phi) / phi, b = (1.0 - std::cos(phi)) / phi;
    Eigen::Matrix2d V;
    V << a, -b, b, a;
    x.segment<2>(r) = Eigen::Rotation2Dd(phi) * x.segment<2>(r) + V * xi.segment<2>(r);
  };
  move(xi(2), 0);
  x(2) += xi(2);
  x.segment<2>(3) += xi.segment<2>(3);
  for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) move(xi(2), ekf.stateRow(int(k)));
  for (const CloneId c : ekf.cloneIds()) {
    const int r = ekf.cloneRow(c);
    move(xi(r + 2), r);
    x(r + 2) += xi(r + 2);
  }
  return x;
}

TEST(InvariantEkf, UpdateIsTheEkfInTheInvariantCoordinates) {
  EkfSlam ekf = makeFilter(Linearisation::kInvariant);
  ASSERT_EQ(ekf.numClones(), 2u);
  const std::vector<Pairing> pairings = testPairings(ekf);
  const Eigen::MatrixXd T = invariantFrame(ekf);
  const Eigen::MatrixXd Pxi =
      T.inverse() * Eigen::MatrixXd(ekf.covariance()) * T.inverse().transpose();
  const Eigen::MatrixXd Hxi = numericH(ekf, pairings) * T;
  // An observation from the current pose sees positions relative to it: no heading column. From a
  // clone it sees the landmark turned by the pose's heading against the clone's: turning every
  // heading together (the global rotation) changes no observation.
  EXPECT_LT(Hxi.topRows<2>().col(2).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(Hxi.bottomRows(4).col(2).cwiseAbs().maxCoeff(), 1.0);
  Eigen::VectorXd headings = Eigen::VectorXd::Zero(Hxi.cols());
  headings(2) = 1.0;
  for (const CloneId c : ekf.cloneIds()) headings(ekf.cloneRow(c) + 2) = 1.0;
  EXPECT_LT((Hxi * headings).cwiseAbs().maxCoeff(), 1e-6);
  Eigen::VectorXd v(2 * pairings.size());
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(v.size(), v.size());
  for (std::size_t i = 0; i < pairings.size(); ++i) {
    const Eigen::Vector3d from =
        pairings[i].clone == kNoClone ? ekf.pose() : ekf.clonePose(pairings[i].clone);
    v.segment<2>(2 * i) = RangeBearingModel::innovation(
        pairings[i].z,
        kModel.predict(from, ekf.landmark(ekf.indexOf(pairings[i].id)),
                       MeasurementKind::kRangeBearing),
        MeasurementKind::kRangeBearing);
    R.block<2, 2>(2 * i, 2 * i) = pairings[i].R;
  }
  const Eigen::MatrixXd S = Hxi * Pxi * Hxi.transpose() + R;
  const Eigen::MatrixXd K = Pxi * Hxi.transpose() * S.inverse();
  const Eigen::MatrixXd Pxi_new = Pxi - K * S * K.transpose();
  const Eigen::VectorXd x_new = exponential(ekf, K * v);

  ASSERT_TRUE(ekf.update(pairings, kModel));
  Eigen::VectorXd dx = ekf.mean() - x_new;
  dx(2) = wrapAngle(dx(2));
  for (const CloneId c : ekf.cloneIds())
    dx(ekf.cloneRow(c) + 2) = wrapAngle(dx(ekf.cloneRow(c) + 2));
  EXPECT_LT(dx.cwiseAbs().maxCoeff(), 1e-7);
  // P_xi is what the filter carries; in the standard coordinates at the corrected estimate:
  const Eigen::MatrixXd T_new = invariantFrame(ekf);
  const Eigen::MatrixXd expected = T_new * Pxi_new * T_new.transpose();
  EXPECT_LT((Eigen::MatrixXd(ekf.covariance()) - expected).cwiseAbs().maxCoeff(), 1e-7);
}

// u^T P^-1 u, the information on the global rotation at the current estimate.
double rotationInformation(const EkfSlam& ekf) {
  const Eigen::VectorXd u = rotationDirection(ekf);
  return u.dot(Eigen::MatrixXd(ekf.covariance()).inverse() * u);
}

// The global rotation is unobservable: an update must not change the information on it. The
// standard EKF does (its H is evaluated at the estimate before the update, and P is left in the
// coordinates of that estimate while the direction moves with the correction).
double rotationInformationGain(Linearisation lin) {
  EkfSlam ekf = makeFilter(lin);
  const double before = rotationInformation(ekf);
  EXPECT_TRUE(ekf.update(testPairings(ekf), kModel));
  return (rotationInformation(ekf) - before) / before;
}

TEST(InvariantEkf, UpdateAddsNoInformationOnTheGlobalRotation) {
  EXPECT_LT(std::abs(rotationInformationGain(Linearisation::kInvariant)), 1e-6);
  EXPECT_GT(std::abs(rotationInformationGain(Linearisation::kStandard)), 1e-2);
}

TEST(InvariantEkf, ParameterResolved) {
  using Values = std::map<std::string, std::string>;
  const auto config = [](const Values& v) { return readPipelineConfig(MapParameterSource(v)); };
  // auto: FEJ, but the invariant EKF where far landmarks need second-order terms.
  EXPECT_EQ(config({}).linearisation(), Linearisation::kFirstEstimate);
  EXPECT_EQ(config({{"second_order_observations", "true"}}).linearisation(),
            Linearisation::kInvariant);
  EXPECT_EQ(config({{"second_order_observations", "true"}, {"filter", "cekf"}}).linearisation(),
            Linearisation::kStandard);
  EXPECT_EQ(config({{"jacobians", "invariant"}}).linearisation(), Linearisation::kInvariant);
  EXPECT_EQ(
      config({{"jacobians", "standard"}, {"second_order_observations", "true"}}).linearisation(),
      Linearisation::kStandard);
  // The compressed EKF defers the re-expression of the whole P: refused.
  EXPECT_THROW(config({{"jacobians", "invariant"}, {"filter", "cekf"}}), ParameterError);
}

}  // namespace test_invariant_ekf
}  // namespace ekf_slam
