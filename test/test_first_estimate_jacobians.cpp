// EkfSlam with Linearisation::kFirstEstimate (FEJ-EKF, docs/consistency.md): the update's H is the
// finite-difference Jacobian of h at the predicted pose and the landmark's FIRST estimate (the
// innovation still from the current estimate), and the propagation's transition carries the
// global-rotation direction at the prior positions onto the one at the new positions (Huang et
// al.'s observability constraint), checked by rotating the whole state numerically. Each check
// is also run on the standard filter, where it must fail: the two linearisations differ here.
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"

namespace ekf_slam {
namespace test_first_estimate_jacobians {

constexpr double kStep = 1e-6;  // central differences: error ~1e-12 relative

const RangeBearingModel kModel(Eigen::Vector3d(0.4, -0.1, 0.05));  // a sensor off the centre

// Central-difference Jacobian of h w.r.t. [pose, landmark] (2 x 5) at (xv, m).
Eigen::Matrix<double, 2, 5> numericH(const Eigen::Vector3d& xv, const Eigen::Vector2d& m,
                                     MeasurementKind kind) {
  Eigen::Matrix<double, 5, 1> s;
  s << xv, m;
  Eigen::Matrix<double, 2, 5> H;
  for (int j = 0; j < 5; ++j) {
    Eigen::Matrix<double, 5, 1> a = s, b = s;
    a(j) += kStep;
    b(j) -= kStep;
    const Eigen::Vector2d za = kModel.predict(a.head<3>(), a.tail<2>(), kind);
    const Eigen::Vector2d zb = kModel.predict(b.head<3>(), b.tail<2>(), kind);
    H.col(j) = RangeBearingModel::innovation(za, zb, kind) / (2.0 * kStep);
  }
  return H;
}

// A filter with two landmarks whose estimates have moved away from their first estimates: set,
// then one update with a biased observation of each.
EkfSlam movedFilter(Linearisation lin, MeasurementKind kind) {
  EkfSlam ekf;
  ekf.setLinearisation(lin);
  ekf.reset(Eigen::Vector3d(1.0, 2.0, 0.3), Eigen::Vector3d(0.3, 0.2, 0.05).asDiagonal());
  const Eigen::Matrix2d Pl = Eigen::Vector2d(0.5, 0.4).asDiagonal();
  ekf.insertLandmark(Eigen::Vector2d(8.0, 5.0), Pl);
  ekf.insertLandmark(Eigen::Vector2d(-3.0, 9.0), Pl);
  std::vector<Pairing> p(2);
  for (int i = 0; i < 2; ++i) {
    p[i].id = ekf.landmarkIds()[i];
    p[i].kind = kind;
    p[i].R = Eigen::Vector2d(0.01, 0.001).asDiagonal();
    p[i].z = kModel.predict(ekf.pose(), ekf.landmark(i), kind) + Eigen::Vector2d(0.4, 0.05);
  }
  EXPECT_TRUE(ekf.update(p, kModel));
  EXPECT_GT((ekf.landmark(0) - ekf.firstEstimate(0)).norm(), 0.05);
  EXPECT_GT((ekf.pose().head<2>() - ekf.priorPosition()).norm(), 0.05);
  return ekf;
}

// The textbook update of (x, P) with one pairing of landmark 0, H given (2 x n).
void denseUpdate(const Eigen::MatrixXd& H, const Eigen::Vector2d& v, const Eigen::Matrix2d& R,
                 Eigen::VectorXd* x, Eigen::MatrixXd* P) {
  const Eigen::Matrix2d S = H * *P * H.transpose() + R;
  const Eigen::MatrixXd K = *P * H.transpose() * S.inverse();
  *x += K * v;
  *P -= K * S * K.transpose();
}

// Max |difference| between the filter's update and the dense one with H from finite differences
// at (pose, first estimate of landmark 0).
double updateMismatch(Linearisation lin, MeasurementKind kind) {
  EkfSlam ekf = movedFilter(lin, kind);
  Eigen::VectorXd x = ekf.mean();
  Eigen::MatrixXd P = ekf.covariance();
  const Eigen::Vector3d xv = ekf.pose();
  Pairing p;
  p.id = ekf.landmarkIds()[0];
  p.kind = kind;
  p.R = Eigen::Vector2d(0.02, 0.002).asDiagonal();
  p.z = kModel.predict(xv, ekf.landmark(0), kind) + Eigen::Vector2d(-0.1, 0.02);

  const Eigen::Matrix<double, 2, 5> Hn = numericH(xv, ekf.firstEstimate(0), kind);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, x.size());
  H.leftCols<3>() = Hn.leftCols<3>();
  H.block<2, 2>(0, ekf.stateRow(0)) = Hn.rightCols<2>();
  // The innovation from the current estimate, whatever the linearisation.
  const Eigen::Vector2d v =
      RangeBearingModel::innovation(p.z, kModel.predict(xv, ekf.landmark(0), kind), kind);
  denseUpdate(H, v, p.R, &x, &P);

  EXPECT_TRUE(ekf.update({p}, kModel));
  Eigen::VectorXd dx = ekf.mean() - x;
  dx(2) = wrapAngle(dx(2));
  return std::max(dx.cwiseAbs().maxCoeff(), (ekf.covariance() - P).cwiseAbs().maxCoeff());
}

TEST(FirstEstimateJacobians, UpdateUsesHAtThePredictedPoseAndTheFirstLandmarkEstimate) {
  for (const MeasurementKind kind : {MeasurementKind::kRangeBearing, MeasurementKind::kCartesian}) {
    EXPECT_LT(updateMismatch(Linearisation::kFirstEstimate, kind), 1e-7);
    // The standard filter linearises at the moved estimate: the same check must fail there.
    EXPECT_GT(updateMismatch(Linearisation::kStandard, kind), 1e-4);
  }
}

// The generator of a global rotation about the origin, d/de of (R(e) p, yaw + e) at e = 0, by
// central differences of the rotation itself.
Eigen::Vector3d rotationDirection(const Eigen::Vector3d& pose) {
  const auto rotated = [&pose](double e) {
    const Eigen::Vector2d p = Eigen::Rotation2Dd(e) * pose.head<2>();
    return Eigen::Vector3d(p(0), p(1), pose(2) + e);
  };
  return (rotated(kStep) - rotated(-kStep)) / (2.0 * kStep);
}

// After an update moved the pose away from its prior, one prediction: its transition F (read
// back from P_vm, which the prediction maps to F P_vm) must carry the rotation direction at the
// prior pose onto the direction at the new pose. Returns the mismatch.
double propagationMismatch(Linearisation lin) {
  EkfSlam ekf = movedFilter(lin, MeasurementKind::kRangeBearing);
  const Eigen::Vector3d prior(ekf.priorPosition()(0), ekf.priorPosition()(1), ekf.pose()(2));
  const Eigen::MatrixXd Pvm = ekf.covariance().topRightCorner(3, 4);  // rank 3 after the update
  const MotionStep step = TwistModel().step(ekf.pose(), Eigen::Vector2d(2.0, 0.3), 0.5);
  EXPECT_TRUE(ekf.predict(step));
  const Eigen::MatrixXd Pvm1 = ekf.covariance().topRightCorner(3, 4);
  const Eigen::Matrix3d F = Pvm1 * Pvm.transpose() * (Pvm * Pvm.transpose()).inverse();
  EXPECT_EQ(ekf.priorPosition(), step.pose.head<2>());
  return (F * rotationDirection(prior) - rotationDirection(step.pose)).cwiseAbs().maxCoeff();
}

TEST(FirstEstimateJacobians, PropagationKeepsTheGlobalRotationUnobservable) {
  EXPECT_LT(propagationMismatch(Linearisation::kFirstEstimate), 1e-6);
  EXPECT_GT(propagationMismatch(Linearisation::kStandard), 1e-2);
}

// A landmark added after an update moved the pose: its pose Jacobian Gv (read back from
// cov(m, pose) = Gv P_vv) must carry the rotation direction at the prior pose onto the new
// landmark's, J m. Returns the mismatch.
double initialisationMismatch(Linearisation lin) {
  EkfSlam ekf = movedFilter(lin, MeasurementKind::kRangeBearing);
  const Eigen::Vector3d prior(ekf.priorPosition()(0), ekf.priorPosition()(1), ekf.pose()(2));
  const Eigen::Matrix3d Pvv = ekf.poseCovariance();
  ekf.addLandmark(Eigen::Vector2d(6.0, 0.7), Eigen::Vector2d(0.01, 0.001).asDiagonal(), kModel);
  const int k = static_cast<int>(ekf.numLandmarks()) - 1;
  const Matrix23d Gv = ekf.covariance().block<2, 3>(ekf.stateRow(k), 0) * Pvv.inverse();
  const Eigen::Vector2d m = ekf.firstEstimate(k);
  EXPECT_EQ(m, ekf.landmark(k));
  const Eigen::Vector2d expected = rotationDirection(Eigen::Vector3d(m(0), m(1), 0.0)).head<2>();
  return (Gv * rotationDirection(prior) - expected).cwiseAbs().maxCoeff();
}

TEST(FirstEstimateJacobians, InitialisationMapsTheRotationDirectionOntoTheLandmark) {
  EXPECT_LT(initialisationMismatch(Linearisation::kFirstEstimate), 1e-6);
  EXPECT_GT(initialisationMismatch(Linearisation::kStandard), 1e-2);
}

TEST(FirstEstimateJacobians, FirstEstimatesFollowTheirLandmarks) {
  EkfSlam ekf;
  ekf.setLinearisation(Linearisation::kFirstEstimate);
  const Eigen::Matrix2d R = Eigen::Vector2d(0.01, 0.001).asDiagonal();
  const LandmarkId a = ekf.addLandmark(Eigen::Vector2d(5.0, 0.1), R, kModel);
  ekf.addLandmark(Eigen::Vector2d(7.0, -0.4), R, kModel);
  const Eigen::Vector2d second = ekf.landmark(1);
  ekf.insertLandmark(Eigen::Vector2d(1.0, 2.0), R);
  ASSERT_TRUE(ekf.removeLandmark(a));
  ASSERT_EQ(ekf.numLandmarks(), 2u);
  EXPECT_EQ(ekf.firstEstimate(0), second);
  EXPECT_EQ(ekf.firstEstimate(1), Eigen::Vector2d(1.0, 2.0));
  // An update moves the landmark, not its first estimate; reset keeps the linearisation.
  Pairing p{ekf.landmarkIds()[0], Eigen::Vector2d(6.5, -0.3), R};
  ASSERT_TRUE(ekf.update({p}, kModel));
  EXPECT_NE(ekf.landmark(0), second);
  EXPECT_EQ(ekf.firstEstimate(0), second);
  ekf.reset();
  EXPECT_EQ(ekf.linearisation(), Linearisation::kFirstEstimate);
}

TEST(FirstEstimateJacobians, ParameterValidated) {
  using Values = std::map<std::string, std::string>;
  // The default: FEJ with the full EKF, standard with second-order terms or the compressed EKF.
  EXPECT_EQ(readPipelineConfig(MapParameterSource()).jacobians, "auto");
  EXPECT_EQ(readPipelineConfig(MapParameterSource()).linearisation(),
            Linearisation::kFirstEstimate);
  EXPECT_EQ(readPipelineConfig(MapParameterSource(Values{{"second_order_observations", "true"}}))
                .linearisation(),
            Linearisation::kInvariant);
  EXPECT_EQ(readPipelineConfig(MapParameterSource(Values{{"filter", "cekf"}})).linearisation(),
            Linearisation::kStandard);
  EXPECT_EQ(
      readPipelineConfig(MapParameterSource(Values{{"jacobians", "standard"}})).linearisation(),
      Linearisation::kStandard);
  EXPECT_EQ(
      readPipelineConfig(MapParameterSource(Values{{"jacobians", "first_estimate"}})).jacobians,
      "first_estimate");
  EXPECT_THROW(readPipelineConfig(MapParameterSource(Values{{"jacobians", "first"}})),
               ParameterError);
  // The compressed EKF does not carry the first estimates through its private filter.
  EXPECT_THROW(readPipelineConfig(
                   MapParameterSource(Values{{"jacobians", "first_estimate"}, {"filter", "cekf"}})),
               ParameterError);
}

}  // namespace test_first_estimate_jacobians
}  // namespace ekf_slam
