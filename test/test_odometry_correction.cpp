// Odometry correction states (AEKF): the corrected twist's Jacobian and the augmented
// prediction's Jacobians against finite differences, composed == per-message prediction,
// convergence of the speed scale on a straight run with a known bias, clamping and refusal.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/odometry_correction.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace ekf_slam {
namespace test_odometry_correction {

const std::vector<std::string> kModes = {"speed_scale", "speed_scale_yaw_bias", "wheel_factors"};

OdometryCorrectionParams params(const std::string& mode) {
  OdometryCorrectionParams p;
  p.mode = mode;
  p.track_width = 1.7;
  return p;
}

// An associator that never pairs anything (pure prediction); it initialises every observation
// of the first scan as a new landmark.
class Blind : public DataAssociation {
 public:
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "Blind"; }
  AssociationResult associate(const AssociationContext& ctx) override {
    AssociationResult r;
    r.resize(ctx.numObservations());
    if (first_) r.decision.assign(ctx.numObservations(), Decision::kNew);
    first_ = false;
    return r;
  }
  void reset() override { first_ = true; }

 private:
  bool first_ = true;
};

TEST(OdometryCorrection, NoneHasNoStates) {
  const OdometryCorrection c;
  EXPECT_EQ(c.dim(), 0);
  EXPECT_TRUE(c.names().empty());
  EXPECT_EQ(c.prior().dim, 0);
  const Eigen::Vector2d u(1.5, 0.2);
  EXPECT_EQ(c.apply(u, Eigen::Vector2d(3.0, 4.0)), u);
}

// odometry_correction: none is the filter as it was before the correction states existed, bit
// for bit: the pose after the last scan of the tiny world (seed 7, DJNN) as printed (%a) by the
// code of commit 1c69b8f built with this build's flags (Release: -O3). The same comparison on
// every scan of tiny, djnn_weak and hybrid with DJNN and NN was identical when this was written.
TEST(OdometryCorrection, NoneIsBitIdenticalToThePlainFilter) {
  const sim::World w = sim::makeWorld("tiny");
  PipelineConfig config = sim::pipelineConfigFor(w);
  ASSERT_EQ(config.correction.mode, "none");
  config.delayed_sightings = false;  // as that filter: new landmarks from their last sighting
  config.jacobians = "standard";     // ... in the standard EKF
  // DJNN's pairings as they were then: an association extension added since (its withheld
  // sightings) changes which landmarks exist, not the filter this test is about.
  auto djnn_params = sim::associatorParametersFor(w, "DJNN");
  djnn_params["tentative_ambiguity"] = "false";
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(djnn_params));
  SlamPipeline p(config, djnn);
  sim::Simulation s(w, 7);
  Eigen::Vector3d x;  // after the last scan
  Eigen::Matrix3d P;
  for (auto e = s.next(); e != sim::Simulation::Event::kEnd; e = s.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      OdometryInput in;
      in.stamp = s.odometry().stamp + 1.0;
      in.twist = s.odometry().twist;
      p.addOdometry(in);
    } else {
      p.processObservations(s.observations().stamp + 1.0, s.observations().toObservations());
      x = p.pose();
      P = p.poseCovariance();
    }
  }
  EXPECT_EQ(x(0), -0x1.918b0d9f4189ep-2);
  EXPECT_EQ(x(1), 0x1.252439a6dd776p+1);
  EXPECT_EQ(x(2), -0x1.70c8d4f454f63p+0);
  EXPECT_EQ(P(0, 0), 0x1.7900d1c697922p-8);
  EXPECT_EQ(P(2, 2), 0x1.d048c0dfa61a8p-11);
  EXPECT_EQ(p.ekf().numLandmarks(), 8u);
}

TEST(OdometryCorrection, NeutralStatesLeaveTheTwist) {
  const Eigen::Vector2d u(2.0, -0.3);
  EXPECT_TRUE(OdometryCorrection(params("speed_scale")).apply(u, {1.0, 0.0}).isApprox(u));
  EXPECT_TRUE(OdometryCorrection(params("speed_scale_yaw_bias")).apply(u, {1.0, 0.0}).isApprox(u));
  EXPECT_TRUE(OdometryCorrection(params("wheel_factors")).apply(u, {1.0, 1.0}).isApprox(u));
  // Unequal wheel factors turn a straight drive into a curve.
  const Eigen::Vector2d c =
      OdometryCorrection(params("wheel_factors")).apply({2.0, 0.0}, {1.0, 1.1});
  EXPECT_NEAR(c(0), 2.1, 1e-12);
  EXPECT_NEAR(c(1), 0.2 / 1.7, 1e-12);
}

TEST(OdometryCorrection, JacobianMatchesFiniteDifferences) {
  const Eigen::Vector2d u(2.3, 0.4);
  const Eigen::Vector2d c0(1.07, 0.96);
  for (const std::string& mode : kModes) {
    const OdometryCorrection oc(params(mode));
    Eigen::Matrix2d J;
    oc.apply(u, c0, &J);
    for (int i = 0; i < 2; ++i) {
      const double h = 1e-6;
      Eigen::Vector2d cp = c0, cm = c0;
      cp(i) += h;
      cm(i) -= h;
      const Eigen::Vector2d num = (oc.apply(u, cp) - oc.apply(u, cm)) / (2 * h);
      if (i >= oc.dim()) {
        EXPECT_TRUE(J.col(i).isZero()) << mode;
        continue;
      }
      EXPECT_LT((J.col(i) - num).cwiseAbs().maxCoeff(), 1e-8) << mode << " state " << i;
    }
  }
}

// Pipeline with zero process noise and a pose known exactly: after pure prediction the
// pose/correction cross-covariance is Fc Sigma_c, so Fc can be read off and compared with the
// finite difference of the predicted pose w.r.t. the initial correction estimate.
std::unique_ptr<SlamPipeline> predictOnly(const std::string& mode, const Eigen::Vector2d& initial) {
  PipelineConfig config;
  config.twist.sigma_v = config.twist.sigma_v_per_v = 0.0;
  config.twist.sigma_w = config.twist.sigma_w_per_v = 0.0;
  config.correction = params(mode);
  config.correction.speed_scale_noise = config.correction.yaw_bias_noise =
      config.correction.wheel_factor_noise = 0.0;
  if (mode == "wheel_factors") {
    config.correction.wheel_factor_initial = initial(0);
  } else {
    config.correction.speed_scale_initial = initial(0);
    config.correction.yaw_bias_initial = initial(1);
  }
  auto p = std::make_unique<SlamPipeline>(config, std::make_shared<Blind>());
  // Irregular stamps, changing twists, several messages composed into one prediction.
  const double stamps[] = {0.0, 0.04, 0.09, 0.1, 0.17, 0.25, 0.31};
  for (int k = 0; k < 7; ++k) {
    OdometryInput o;
    o.stamp = stamps[k];
    o.twist = Eigen::Vector2d(2.0 + 0.3 * k, 0.4 * std::sin(1.0 + k));
    p->addOdometry(o);
  }
  p->processObservations(0.38, {});
  return p;
}

TEST(OdometryCorrection, AugmentedPredictionJacobianMatchesFiniteDifferences) {
  for (const std::string& mode : kModes) {
    const Eigen::Vector2d c0(1.05, mode == "wheel_factors" ? 1.05 : 0.02);
    const std::unique_ptr<SlamPipeline> pipeline = predictOnly(mode, c0);
    const SlamPipeline& p = *pipeline;
    const EkfSlam& ekf = p.ekf();
    const int k = ekf.correctionDim();
    ASSERT_EQ(k, mode == "speed_scale" ? 1 : 2);
    // Fc = P_vc Sigma_c^-1 (Sigma_c diagonal: the prior).
    const Eigen::MatrixXd Pvc = ekf.covariance().block(0, 3, 3, k);
    const Eigen::Vector2d sigma = OdometryCorrection(params(mode)).prior().sigma;
    for (int i = 0; i < k; ++i) {
      const Eigen::Vector3d Fc = Pvc.col(i) / (sigma(i) * sigma(i));
      // Wheel factors share one initial value: perturb both and compare with the sum of columns.
      if (mode == "wheel_factors") {
        if (i == 1) continue;
        const double h = 1e-6;
        const Eigen::Vector3d num = (predictOnly(mode, {c0(0) + h, 0})->pose() -
                                     predictOnly(mode, {c0(0) - h, 0})->pose()) /
                                    (2 * h);
        const Eigen::Vector3d sum = (Pvc.col(0) + Pvc.col(1)) / (sigma(0) * sigma(0));
        EXPECT_LT((sum - num).cwiseAbs().maxCoeff(), 1e-6) << mode;
        continue;
      }
      const double h = 1e-6;
      Eigen::Vector2d cp = c0, cm = c0;
      cp(i) += h;
      cm(i) -= h;
      const Eigen::Vector3d num =
          (predictOnly(mode, cp)->pose() - predictOnly(mode, cm)->pose()) / (2 * h);
      EXPECT_LT((Fc - num).cwiseAbs().maxCoeff(), 1e-6) << mode << " state " << i;
      EXPECT_GT(Fc.norm(), 1e-3) << mode;  // not vacuous
    }
    // The pose covariance is Fc Sigma_c Fc^T (no process noise, pose known at the start).
    const Eigen::MatrixXd Fc = Pvc * sigma.head(k).cwiseAbs2().cwiseInverse().asDiagonal();
    const Eigen::Matrix3d expected = Fc * sigma.head(k).cwiseAbs2().asDiagonal() * Fc.transpose();
    EXPECT_LT((ekf.poseCovariance() - expected).cwiseAbs().maxCoeff(), 1e-10) << mode;
  }
}

// Composing several odometry steps into one prediction (with every noise term: twist noise and
// the states' random walk) equals predicting message by message.
TEST(OdometryCorrection, ComposedPredictionEqualsPerMessagePrediction) {
  for (const std::string& mode : kModes) {
    PipelineConfig config;
    config.correction = params(mode);
    config.correction.speed_scale_noise = config.correction.wheel_factor_noise = 0.01;
    config.correction.yaw_bias_noise = 0.003;
    config.initial_pose_sigma = Eigen::Vector3d(0.1, 0.2, 0.05);
    SlamPipeline lazy(config, std::make_shared<Blind>());
    SlamPipeline eager(config, std::make_shared<Blind>());
    // A landmark so that the pose/map block is exercised too.
    Observation o;
    o.z = Eigen::Vector2d(10.0, 0.3);
    o.R = Eigen::Vector2d(0.01, 0.001).asDiagonal();
    for (SlamPipeline* p : {&lazy, &eager}) {
      p->processObservations(0.0, {o});
      ASSERT_EQ(p->ekf().numLandmarks(), 1u);
    }
    const double stamps[] = {0.0, 0.03, 0.07, 0.1, 0.18, 0.2};
    for (int k = 0; k < 6; ++k) {
      OdometryInput in;
      in.stamp = stamps[k] + 0.01;
      in.twist = Eigen::Vector2d(3.0 - 0.2 * k, 0.5 * std::cos(2.0 + k));
      lazy.addOdometry(in);
      eager.addOdometry(in);
      eager.ekf();  // applies the pending step now
      EXPECT_LT((lazy.poseCovariance() - eager.poseCovariance()).cwiseAbs().maxCoeff(), 1e-12)
          << mode;
    }
    lazy.processObservations(0.3, {});
    eager.processObservations(0.3, {});
    const Eigen::MatrixXd& A = lazy.ekf().covariance();
    const Eigen::MatrixXd& B = eager.ekf().covariance();
    ASSERT_EQ(A.rows(), B.rows());
    EXPECT_LT((A - B).cwiseAbs().maxCoeff(), 1e-10) << mode;
    EXPECT_LT((lazy.ekf().mean() - eager.ekf().mean()).cwiseAbs().maxCoeff(), 1e-12) << mode;
    EXPECT_GT(A.block(0, 3, 3, A.rows() - 3).cwiseAbs().maxCoeff(), 1e-3);  // not vacuous
  }
}

// A straight run past a row of landmarks with odometry reporting 1 / 1.1 of the true speed: the
// estimated scale converges to 1.1 and the plain filter's position error is larger.
sim::World straightWorld() {
  sim::World w;
  w.name = "straight";
  w.area_min = {-10.0, -20.0};
  w.area_max = {320.0, 20.0};
  w.waypoints = {{300.0, 0.0}};
  for (int i = 0; i < 32; ++i) {
    w.landmarks.emplace_back(10.0 * i, 8.0);
    w.landmarks.emplace_back(10.0 * i + 5.0, -8.0);
  }
  w.vehicle.speed = 3.0;
  w.sensor.max_range = 20.0;
  w.noise.sigma_speed = 0.1;
  w.noise.sigma_steer = 0.01;
  w.noise.sigma_range = 0.1;
  w.noise.sigma_bearing = 0.01;
  w.noise.odometry_speed_scale = 1.0 / 1.1;
  return w;
}

TEST(OdometryCorrection, SpeedScaleConvergesOnAStraightRun) {
  const sim::World w = straightWorld();
  PipelineConfig config = sim::pipelineConfigFor(w);
  config.correction.mode = "speed_scale";
  const auto nn = std::make_shared<NN>();
  nn->configure(MapParameterSource());
  const RunMetrics aekf = runSimulation(w, 3, config, nn);
  ASSERT_EQ(aekf.correction_names, std::vector<std::string>{"speed_scale"});
  EXPECT_GT(aekf.correction_sigma(0), 0.0);
  EXPECT_LT(aekf.correction_sigma(0), 0.01);
  EXPECT_NEAR(aekf.correction(0), 1.1, 3.0 * aekf.correction_sigma(0));
  EXPECT_DOUBLE_EQ(sim::trueCorrection(w, "speed_scale")(0), 1.1);

  config.correction.mode = "none";
  const RunMetrics plain = runSimulation(w, 3, config, nn);
  EXPECT_TRUE(plain.correction_names.empty());
  EXPECT_LT(aekf.pose_rmse_m, plain.pose_rmse_m);
}

// Loading a map keeps the correction estimates (and their variances); reset() returns to the
// prior.
TEST(OdometryCorrection, LoadMapKeepsTheEstimatesAndResetRestoresThePrior) {
  const sim::World w = straightWorld();
  PipelineConfig config = sim::pipelineConfigFor(w);
  config.correction.mode = "speed_scale";
  const auto nn = std::make_shared<NN>();
  nn->configure(MapParameterSource());
  SlamPipeline p(config, nn);
  sim::Simulation s(w, 3);
  int sets = 0;
  for (auto e = s.next(); e != sim::Simulation::Event::kEnd && sets < 200; e = s.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      OdometryInput in;
      in.stamp = s.odometry().stamp;
      in.twist = s.odometry().twist;
      p.addOdometry(in);
    } else {
      p.processObservations(s.observations().stamp, s.observations().toObservations());
      ++sets;
    }
  }
  const Eigen::Vector2d c = p.ekf().correction();
  const Eigen::Matrix2d C = p.ekf().correctionCovariance();
  ASSERT_GT(std::abs(c(0) - 1.0), 0.02);  // it moved towards 1.1
  const std::string path = testing::TempDir() + "/aekf_map.txt";
  p.saveMap(path);
  p.loadMap(path, /*reset_pose=*/false);
  EXPECT_EQ(p.ekf().correction(), c);
  EXPECT_DOUBLE_EQ(p.ekf().correctionCovariance()(0, 0), C(0, 0));
  EXPECT_GT(p.ekf().numLandmarks(), 5u);
  p.reset();
  EXPECT_EQ(p.ekf().correction()(0), 1.0);
  EXPECT_DOUBLE_EQ(p.ekf().correctionCovariance()(0, 0), 0.01);
  std::remove(path.c_str());
}

// An update that would push the speed scale below its bound is clamped (counted): the
// correction never reverses the speed, and nothing becomes NaN.
TEST(OdometryCorrection, UpdateBeyondTheBoundsIsClampedAndCounted) {
  EkfSlam ekf;
  CorrectionPrior prior = OdometryCorrection(params("speed_scale")).prior();
  ekf.reset(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity() * 1e-6, prior);
  const RangeBearingModel model;
  const LandmarkId id =
      ekf.addLandmark({10.0, 0.0}, Eigen::Vector2d(1e-6, 1e-6).asDiagonal(), model);
  // The scale explains the distance travelled: strongly correlated with x.
  Eigen::MatrixXd P = ekf.covariance();
  P(0, 0) = 1.0;
  P(0, 3) = P(3, 0) = 0.9 * std::sqrt(P(0, 0) * P(3, 3));
  ekf.setState(ekf.mean(), P, ekf.landmarkIds());
  // The landmark seen 8 m further away than predicted: x must move back, the scale far down.
  const std::vector<Pairing> z = {{id, {18.0, 0.0}, Eigen::Vector2d(1e-4, 1e-6).asDiagonal()}};
  ASSERT_TRUE(ekf.update(z, model));
  EXPECT_EQ(ekf.correctionClamps(), 1u);
  EXPECT_DOUBLE_EQ(ekf.correction()(0), prior.lower(0));
  EXPECT_GT(ekf.correction()(0), 0.0);
  EXPECT_TRUE(ekf.mean().allFinite() && ekf.covariance().allFinite());
}

// With a covariance that is not positive definite (cov(x, scale) beyond what the variances
// allow), the update would leave the scale with a negative variance: refused, state unchanged.
TEST(OdometryCorrection, UpdateThatBreaksPositiveDefinitenessIsRefused) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity() * 1e-4,
            OdometryCorrection(params("speed_scale")).prior());
  const RangeBearingModel model;
  const LandmarkId id =
      ekf.addLandmark({10.0, 0.0}, Eigen::Vector2d(1e-4, 1e-6).asDiagonal(), model);
  Eigen::MatrixXd P = ekf.covariance();
  P(0, 0) = 1.0;
  P(3, 3) = 1e-4;
  P(0, 3) = P(3, 0) = 0.5;  // |rho| = 50
  ekf.setState(ekf.mean(), P, ekf.landmarkIds());
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  const std::vector<Pairing> z = {{id, {10.5, 0.0}, Eigen::Vector2d(1e-4, 1e-6).asDiagonal()}};
  EXPECT_FALSE(ekf.update(z, model));
  EXPECT_EQ(ekf.correctionRefusals(), 1u);
  EXPECT_EQ(ekf.mean(), x0);
  EXPECT_EQ(ekf.covariance(), P0);
}

// Landmark rows move behind the correction states; every accessor follows.
TEST(OdometryCorrection, LandmarkAccessorsSkipTheCorrectionStates) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d(1.0, 2.0, 0.0), Eigen::Matrix3d::Identity() * 0.01,
            OdometryCorrection(params("wheel_factors")).prior());
  const RangeBearingModel model;
  const LandmarkId a = ekf.addLandmark({5.0, 0.0}, Eigen::Matrix2d::Identity() * 0.01, model);
  const LandmarkId b = ekf.addLandmark({5.0, M_PI / 2}, Eigen::Matrix2d::Identity() * 0.01, model);
  ASSERT_EQ(ekf.mean().size(), 3 + 2 + 4);
  EXPECT_EQ(ekf.stateRow(0), 5);
  EXPECT_TRUE(ekf.landmark(ekf.indexOf(a)).isApprox(Eigen::Vector2d(6.0, 2.0)));
  EXPECT_TRUE(ekf.landmark(ekf.indexOf(b)).isApprox(Eigen::Vector2d(1.0, 7.0)));
  EXPECT_TRUE(ekf.correction().isApprox(Eigen::Vector2d(1.0, 1.0)));
  EXPECT_NEAR(ekf.correctionCovariance()(0, 0), 0.1, 1e-12);
  // The new landmark is uncorrelated with the correction states (they did not move yet).
  EXPECT_TRUE(ekf.covariance().block(3, 5, 2, 4).isZero());
  ASSERT_TRUE(ekf.removeLandmark(a));
  EXPECT_TRUE(ekf.landmark(ekf.indexOf(b)).isApprox(Eigen::Vector2d(1.0, 7.0)));
  EXPECT_TRUE(ekf.correction().isApprox(Eigen::Vector2d(1.0, 1.0)));
}

}  // namespace test_odometry_correction
}  // namespace ekf_slam
