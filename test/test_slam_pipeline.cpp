// SlamPipeline: convergence, composed prediction == per-message prediction, odometry modes,
// exact scan stamps, bad input, landmark life cycle, association fix-ups, map files.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"

namespace ekf_slam {
namespace test_slam_pipeline {

// An associator whose decisions come from a function; records landmarkAdded() calls.
class ScriptedAssociator : public DataAssociation {
 public:
  using Script = std::function<AssociationResult(const AssociationContext&)>;
  explicit ScriptedAssociator(Script script = nullptr) : script_(std::move(script)) {}
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "Scripted"; }
  AssociationResult associate(const AssociationContext& ctx) override {
    last_observations = ctx.observations();
    if (script_) return script_(ctx);
    AssociationResult r;
    r.resize(ctx.numObservations());
    return r;
  }
  void landmarkAdded(int obs, LandmarkId id) override { added.emplace_back(obs, id); }
  void reset() override { ++resets; }

  Script script_;
  std::vector<std::pair<int, LandmarkId>> added;
  std::vector<Observation> last_observations;
  int resets = 0;
};

// Pairs by the observation's descriptor, used as a truth key: known key -> its landmark, unknown
// key -> kNew (the id is learnt in landmarkAdded).
class OracleAssociator : public ScriptedAssociator {
 public:
  OracleAssociator() {
    script_ = [this](const AssociationContext& ctx) {
      AssociationResult r;
      r.resize(ctx.numObservations());
      for (std::size_t i = 0; i < ctx.numObservations(); ++i) {
        const auto it = id_of.find(static_cast<int>(ctx.observations()[i].descriptor));
        if (it != id_of.end() && ctx.ekf().contains(it->second)) {
          r.pair(i, it->second);
        } else {
          r.decision[i] = Decision::kNew;
        }
      }
      return r;
    };
  }
  void landmarkAdded(int obs, LandmarkId id) override {
    ScriptedAssociator::landmarkAdded(obs, id);
    id_of[static_cast<int>(last_observations[obs].descriptor)] = id;
  }
  void reset() override {
    ScriptedAssociator::reset();
    id_of.clear();
  }
  std::map<int, LandmarkId> id_of;
};

OdometryInput odom(double stamp, double v, double w, const Eigen::Vector3d& pose = {0, 0, 0}) {
  OdometryInput o;
  o.stamp = stamp;
  o.twist = Eigen::Vector2d(v, w);
  o.pose = pose;
  return o;
}

// Noise-free observation of landmark `key` (descriptor = key) from `pose`.
Observation observe(const RangeBearingModel& model, const Eigen::Vector3d& pose,
                    const Eigen::Vector2d& p, int key, std::mt19937* rng = nullptr, double sr = 0.0,
                    double sb = 0.0) {
  Observation o;
  o.z = model.predict(pose, p);
  if (rng) {
    std::normal_distribution<double> n01(0.0, 1.0);
    o.z += Eigen::Vector2d(sr * n01(*rng), sb * n01(*rng));
  }
  o.z(1) = wrapAngle(o.z(1));
  o.R.setZero();  // -> the configured default
  o.descriptor = key;
  return o;
}

bool stateFinite(const SlamPipeline& p) {
  return p.ekf().mean().allFinite() && p.ekf().covariance().allFinite() && p.pose().allFinite() &&
         p.poseCovariance().allFinite();
}

PipelineConfig smallNoiseConfig() {
  PipelineConfig c;
  c.initial_pose_sigma = Eigen::Vector3d(0.01, 0.01, 0.001);
  c.sigma_range = 0.1;
  c.sigma_bearing = deg2rad(0.5);
  return c;
}

// --- convergence -------------------------------------------------------------------------------

TEST(SlamPipeline, MovingRobotConvergesOnLandmarks) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n01(0.0, 1.0);
  PipelineConfig c = smallNoiseConfig();
  auto assoc = std::make_shared<OracleAssociator>();
  SlamPipeline p(c, assoc);
  p.setSensorOffset(Eigen::Vector3d(0.5, 0.2, 0.0));
  const std::vector<Eigen::Vector2d> marks = {{12, 4}, {15, -3}, {20, 1}};
  const TwistModel exact;
  Eigen::Vector3d truth = c.initial_pose;
  const double dt = 0.025;
  double first_trace = 0.0, last_trace = 0.0;
  for (int k = 0; k <= 400; ++k) {
    const Eigen::Vector2d u(1.0, 0.02);
    OdometryInput o = odom(k * dt, u(0) + 0.05 * n01(rng), u(1) + 0.005 * n01(rng));
    ASSERT_TRUE(p.addOdometry(o));
    if (k % 8 == 4) {
      std::vector<Observation> obs;
      for (int j = 0; j < 3; ++j)
        obs.push_back(observe(p.observationModel(), truth, marks[j], j, &rng, 0.1, deg2rad(0.5)));
      const ScanReport r = p.processObservations(k * dt, obs);
      ASSERT_TRUE(r.update_ok);
      const int idx = p.ekf().indexOf(assoc->id_of.at(0));
      ASSERT_GE(idx, 0);
      const double tr = p.ekf().landmarkCovariance(idx).trace();
      if (first_trace == 0.0) first_trace = tr;
      last_trace = tr;
    }
    truth = exact.predict(truth, u, dt);
  }
  ASSERT_EQ(p.ekf().numLandmarks(), 3u);
  for (int j = 0; j < 3; ++j) {
    const int idx = p.ekf().indexOf(assoc->id_of.at(j));
    EXPECT_LT((p.ekf().landmark(idx) - marks[j]).norm(), 0.3) << "landmark " << j;
    EXPECT_EQ(p.landmarkInfo(assoc->id_of.at(j)).times_observed, 50u);
    EXPECT_DOUBLE_EQ(p.landmarkInfo(assoc->id_of.at(j)).diameter, j);
  }
  EXPECT_LT(last_trace, 0.5 * first_trace);
  EXPECT_LT((p.pose().head<2>() - truth.head<2>()).norm(), 0.3);
  EXPECT_LT(std::abs(wrapAngle(p.pose()(2) - truth(2))), 0.02);
  EXPECT_EQ(p.counters().scans, 50u);
  EXPECT_EQ(p.counters().odometry, 401u);
}

// --- the composed prediction -------------------------------------------------------------------

// Builds a map of 4 landmarks (so the pose-map cross-covariance matters), returns the pipeline.
std::unique_ptr<SlamPipeline> pipelineWithMap(const std::string& mode,
                                              std::shared_ptr<DataAssociation> assoc) {
  PipelineConfig c = smallNoiseConfig();
  c.odometry_mode = mode;
  c.initial_pose_sigma = Eigen::Vector3d(0.3, 0.2, 0.05);
  c.twist.additive = Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal();
  auto p = std::make_unique<SlamPipeline>(c, assoc);
  std::vector<Observation> obs;
  const std::vector<Eigen::Vector2d> marks = {{10, 3}, {-5, 8}, {4, -9}, {15, 15}};
  for (int j = 0; j < 4; ++j)
    obs.push_back(observe(p->observationModel(), c.initial_pose, marks[j], j));
  p->addOdometry(odom(0.0, 0.0, 0.0));
  p->processObservations(0.0, obs);
  EXPECT_EQ(p->ekf().numLandmarks(), 4u);
  return p;
}

TEST(SlamPipeline, ComposedPredictionEqualsPerMessagePrediction) {
  auto oracle = std::make_shared<OracleAssociator>();
  auto p = pipelineWithMap("twist", oracle);
  oracle->script_ = nullptr;  // from now on reject everything: no updates, pure prediction
  EkfSlam ref = p->ekf();     // copy
  const TwistModel model(p->config().twist);

  // Irregular stamps and changing twists; the scan falls between two messages.
  const std::vector<double> stamps = {0.02, 0.05, 0.071, 0.1, 0.13, 0.2, 0.26, 0.3, 0.4};
  Eigen::Vector2d u(0.0, 0.0);  // twist of the message at 0.0
  double t = 0.0;
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    const Eigen::Vector2d next(2.0 + 0.5 * k, 0.3 * std::sin(1.0 + k));
    ASSERT_TRUE(p->addOdometry(odom(stamps[k], next(0), next(1))));
    ASSERT_TRUE(ref.predict(model.step(ref.pose(), u, stamps[k] - t)));
    u = next;
    t = stamps[k];
    // pose() and poseCovariance() include the pending motion without touching the EKF.
    EXPECT_LT((p->pose() - ref.pose()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((p->poseCovariance() - ref.poseCovariance()).cwiseAbs().maxCoeff(), 1e-12);
  }
  const double scan_stamp = 0.47;
  ASSERT_TRUE(ref.predict(model.step(ref.pose(), u, scan_stamp - t)));
  p->processObservations(scan_stamp, {});
  EXPECT_DOUBLE_EQ(p->time(), scan_stamp);
  ASSERT_EQ(p->ekf().mean().size(), ref.mean().size());
  EXPECT_LT((p->ekf().mean() - ref.mean()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((p->ekf().covariance() - ref.covariance()).cwiseAbs().maxCoeff(), 1e-9);
  // The cross-covariance did change (the check above is not vacuous).
  EXPECT_GT((p->ekf().covariance() -
             pipelineWithMap("twist", std::make_shared<OracleAssociator>())->ekf().covariance())
                .cwiseAbs()
                .maxCoeff(),
            1e-3);
}

TEST(SlamPipeline, ComposedPoseDeltaPredictionEqualsPerMessagePrediction) {
  auto oracle = std::make_shared<OracleAssociator>();
  auto p = pipelineWithMap("pose_delta", oracle);
  oracle->script_ = nullptr;
  EkfSlam ref = p->ekf();
  const PoseDeltaModel model(p->config().pose_delta);
  Eigen::Vector3d prev(0, 0, 0);
  for (int k = 1; k <= 12; ++k) {
    const Eigen::Vector3d pose(0.3 * k, 0.05 * k * k, 0.1 * k);
    ASSERT_TRUE(p->addOdometry(odom(0.1 * k, 1.0, 0.1, pose)));
    ASSERT_TRUE(ref.predict(model.step(ref.pose(), PoseDeltaModel::between(prev, pose))));
    prev = pose;
  }
  p->processObservations(1.2, {});
  EXPECT_LT((p->ekf().mean() - ref.mean()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((p->ekf().covariance() - ref.covariance()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(SlamPipeline, TwistAndPoseDeltaGiveTheSameTrajectory) {
  auto a = std::make_shared<ScriptedAssociator>();
  PipelineConfig ct;
  PipelineConfig cd;
  cd.odometry_mode = "pose_delta";
  SlamPipeline twist(ct, a), delta(cd, std::make_shared<ScriptedAssociator>());
  // Odometry poses integrated as victoria_park_to_bag does: twist k held over [t_k, t_k+1].
  const TwistModel exact;
  Eigen::Vector3d pose(0, 0, 0);
  double t = 0.0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector2d u(3.0 + std::sin(0.05 * k), 0.4 * std::cos(0.03 * k));
    const OdometryInput o = odom(t, u(0), u(1), pose);
    ASSERT_TRUE(twist.addOdometry(o));
    ASSERT_TRUE(delta.addOdometry(o));
    const double dt = 0.025 + 0.01 * (k % 3);
    if (k % 7 == 3) {  // two scans inside this odometry interval
      twist.processObservations(t + 0.3 * dt, {});
      delta.processObservations(t + 0.3 * dt, {});
      twist.processObservations(t + 0.8 * dt, {});
      delta.processObservations(t + 0.8 * dt, {});
      EXPECT_LT((twist.pose() - delta.pose()).cwiseAbs().maxCoeff(), 1e-9) << "scan at " << t;
    }
    pose = exact.predict(pose, u, dt);
    t += dt;
  }
  EXPECT_LT((twist.pose() - delta.pose()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(twist.pose().head<2>().norm(), 10.0);
}

TEST(SlamPipeline, ScanBetweenOdometryIsPredictedToItsExactStamp) {
  SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  p.addOdometry(odom(10.0, 2.0, 0.5));
  const ScanReport r = p.processObservations(10.4, {});
  EXPECT_FALSE(r.late);
  EXPECT_DOUBLE_EQ(r.stamp, 10.4);
  EXPECT_DOUBLE_EQ(p.time(), 10.4);
  const Eigen::Vector3d expected = TwistModel().predict(Eigen::Vector3d::Zero(), {2.0, 0.5}, 0.4);
  EXPECT_LT((p.ekf().pose() - expected).norm(), 1e-12);
  // The next message finishes the interval with the same twist.
  p.addOdometry(odom(11.0, 0.0, 0.0));
  const Eigen::Vector3d end = TwistModel().predict(Eigen::Vector3d::Zero(), {2.0, 0.5}, 1.0);
  EXPECT_LT((p.pose() - end).norm(), 1e-12);
}

// --- bad input ---------------------------------------------------------------------------------

TEST(SlamPipeline, NonFiniteAndLateOdometryIsCountedAndSkipped) {
  SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  EXPECT_TRUE(p.addOdometry(odom(1.0, 1.0, 0.0)));
  EXPECT_FALSE(p.addOdometry(odom(1.1, NAN, 0.0)));
  EXPECT_FALSE(p.addOdometry(odom(1.1, 1.0, INFINITY)));
  EXPECT_FALSE(p.addOdometry(odom(NAN, 1.0, 0.0)));
  EXPECT_EQ(p.counters().rejected_odometry, 3u);
  EXPECT_TRUE(p.addOdometry(odom(2.0, 1.0, 0.0)));
  EXPECT_FALSE(p.addOdometry(odom(1.5, 1.0, 0.0)));  // older than time()
  EXPECT_EQ(p.counters().late_odometry, 1u);
  EXPECT_TRUE(p.addOdometry(odom(4.0, 1.0, 0.0)));  // a 2 s gap
  EXPECT_EQ(p.counters().odometry_gaps, 1u);
  EXPECT_TRUE(stateFinite(p));
  EXPECT_NEAR(p.pose().x(), 3.0, 1e-12);
}

TEST(SlamPipeline, PoseDeltaRejectsNonFinitePoses) {
  PipelineConfig c;
  c.odometry_mode = "pose_delta";
  SlamPipeline p(c, std::make_shared<ScriptedAssociator>());
  EXPECT_TRUE(p.addOdometry(odom(0.0, 0.0, 0.0)));
  EXPECT_FALSE(p.addOdometry(odom(0.1, 0.0, 0.0, Eigen::Vector3d(NAN, 0, 0))));
  EXPECT_EQ(p.counters().rejected_odometry, 1u);
  EXPECT_TRUE(stateFinite(p));
}

TEST(SlamPipeline, ImplausibleTwistIsRejectedApartFromNonFinite) {
  SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  EXPECT_TRUE(p.addOdometry(odom(1.0, 1.0, 0.0)));
  EXPECT_FALSE(p.addOdometry(odom(1.1, 1e300, 0.0)));  // finite, impossible
  EXPECT_FALSE(p.addOdometry(odom(1.2, 1.0, -50.0)));  // beyond max_yaw_rate 10 rad/s
  EXPECT_EQ(p.counters().implausible_odometry, 2u);
  EXPECT_EQ(p.counters().rejected_odometry, 0u);
  EXPECT_TRUE(p.addOdometry(odom(2.0, 1.0, 0.0)));  // the pose still moves
  EXPECT_NEAR(p.pose().x(), 1.0, 1e-12);
  EXPECT_TRUE(stateFinite(p));
}

TEST(SlamPipeline, PoseDeltaRejectsOdometryWithoutOrientation) {
  PipelineConfig c;
  c.odometry_mode = "pose_delta";
  SlamPipeline p(c, std::make_shared<ScriptedAssociator>());
  EXPECT_TRUE(p.addOdometry(odom(0.0, 0.0, 0.0)));
  OdometryInput zero = odom(0.1, 0.0, 0.0, Eigen::Vector3d(1, 0, 0));
  zero.orientation_valid = false;  // what toOdometryInput makes of an all-zero quaternion
  EXPECT_FALSE(p.addOdometry(zero));
  EXPECT_EQ(p.counters().invalid_orientations, 1u);
  // Twist mode does not use the pose: accepted there.
  SlamPipeline q(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  EXPECT_TRUE(q.addOdometry(zero));
}

TEST(SlamPipeline, LateScanIsProcessedAtTheCurrentTime) {
  SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  p.addOdometry(odom(5.0, 1.0, 0.0));
  p.addOdometry(odom(6.0, 1.0, 0.0));
  const ScanReport r = p.processObservations(5.5, {});
  EXPECT_TRUE(r.late);
  EXPECT_DOUBLE_EQ(r.stamp, 6.0);
  EXPECT_EQ(p.counters().late_scans, 1u);
  EXPECT_NEAR(p.pose().x(), 1.0, 1e-12);  // no motion backwards or forwards
}

// An associator that makes every observation a new landmark.
std::shared_ptr<ScriptedAssociator> everythingNew() {
  return std::make_shared<ScriptedAssociator>([](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    for (auto& d : r.decision) d = Decision::kNew;
    return r;
  });
}

// A 361-beam, 0.5-deg scan (Victoria Park geometry) with one trunk at 10 m, bearing ~0.
std::vector<float> scanWithOneTree() {
  std::vector<float> r(361, 80.0f);  // beyond the extractor's max range: no return
  for (int i = 179; i <= 182; ++i) r[i] = 10.0f;
  return r;
}

TEST(SlamPipeline, ScanExtractsTreesIntoObservations) {
  auto a = everythingNew();
  SlamPipeline p(PipelineConfig(), a);
  p.addOdometry(odom(0.0, 0.0, 0.0));
  const ScanReport r = p.processScan(0.1, scanWithOneTree(), -M_PI / 2, M_PI / 360);
  ASSERT_EQ(r.observations.size(), 1u);
  EXPECT_NEAR(r.observations[0].z(0), 10.0, 0.5);
  EXPECT_NEAR(r.observations[0].z(1), 0.0, deg2rad(1.5));
  EXPECT_GT(r.observations[0].descriptor, 0.0);
  EXPECT_NEAR(r.observations[0].R(0, 0), 0.25, 1e-12);
  EXPECT_EQ(p.ekf().numLandmarks(), 1u);

  // Out of [min, max]_observation_range: not an observation.
  PipelineConfig near;
  near.max_observation_range = 8.0;
  SlamPipeline q(near, a);
  EXPECT_TRUE(q.processScan(0.1, scanWithOneTree(), -M_PI / 2, M_PI / 360).observations.empty());
}

TEST(SlamPipeline, NaNRangesAndEmptyScansAreCountedAndHarmless) {
  auto a = std::make_shared<ScriptedAssociator>();
  SlamPipeline p(PipelineConfig(), a);
  p.addOdometry(odom(0.0, 1.0, 0.1));
  std::vector<float> r = scanWithOneTree();
  r[10] = NAN;
  r[20] = -1.0f;
  r[30] = INFINITY;  // a valid "no return"
  ScanReport rep = p.processScan(0.1, r, -M_PI / 2, M_PI / 360);
  EXPECT_EQ(p.counters().invalid_ranges, 2u);
  EXPECT_EQ(rep.observations.size(), 1u);

  rep = p.processScan(0.2, {}, -M_PI / 2, M_PI / 360);
  EXPECT_TRUE(rep.observations.empty());
  rep = p.processScan(0.3, std::vector<float>(361, NAN), -M_PI / 2, M_PI / 360);
  EXPECT_TRUE(rep.observations.empty());
  rep = p.processScan(0.4, scanWithOneTree(), NAN, M_PI / 360);
  EXPECT_TRUE(rep.observations.empty());
  EXPECT_EQ(p.counters().empty_scans, 3u);
  EXPECT_EQ(p.counters().invalid_ranges, 363u);
  EXPECT_EQ(p.counters().scans, 4u);
  EXPECT_EQ(rep.scan, 3u);
  EXPECT_DOUBLE_EQ(p.time(), 0.4);  // still predicted
  EXPECT_TRUE(stateFinite(p));
}

TEST(SlamPipeline, DuplicateScansAreDroppedAndCounted) {
  auto a = std::make_shared<ScriptedAssociator>();
  SlamPipeline p(PipelineConfig(), a);
  p.addOdometry(odom(0.0, 1.0, 0.0));
  const std::vector<float> r = scanWithOneTree();
  EXPECT_FALSE(p.processScan(0.1, r, -M_PI / 2, M_PI / 360).duplicate);
  const ScanReport again = p.processScan(0.1, r, -M_PI / 2, M_PI / 360);
  EXPECT_TRUE(again.duplicate);
  EXPECT_EQ(p.counters().duplicate_scans, 1u);
  EXPECT_EQ(p.counters().scans, 1u);
  std::vector<float> other = r;
  other[0] = 5.0f;  // same stamp, other content: a scan of its own
  EXPECT_FALSE(p.processScan(0.1, other, -M_PI / 2, M_PI / 360).duplicate);
  EXPECT_FALSE(p.processScan(0.2, r, -M_PI / 2, M_PI / 360).duplicate);
  EXPECT_EQ(p.counters().scans, 3u);
}

TEST(SlamPipeline, InconsistentScanGeometryIsPredictionOnly) {
  auto a = everythingNew();
  SlamPipeline p(PipelineConfig(), a);
  p.addOdometry(odom(0.0, 1.0, 0.0));
  const std::vector<float> r = scanWithOneTree();
  // Consistent (361 beams, -90..90 deg): used.
  ScanReport rep = p.processScan(0.1, r, -M_PI / 2, M_PI / 360, M_PI / 2);
  EXPECT_EQ(rep.geometry_error, nullptr);
  EXPECT_EQ(p.ekf().numLandmarks(), 1u);
  std::vector<float> longer(3 * r.size(), 80.0f);  // 3x the beams for the same angles
  rep = p.processScan(0.2, longer, -M_PI / 2, M_PI / 360, M_PI / 2);
  ASSERT_NE(rep.geometry_error, nullptr);
  EXPECT_NE(std::string(rep.geometry_error).find("number of ranges"), std::string::npos);
  rep = p.processScan(0.3, r, -M_PI / 2, -M_PI / 360, M_PI / 2);  // sign contradicts
  ASSERT_NE(rep.geometry_error, nullptr);
  rep = p.processScan(0.4, r, -M_PI / 2, 1.0, M_PI / 2);  // absurd increment
  ASSERT_NE(rep.geometry_error, nullptr);
  rep = p.processScan(0.5, r, -M_PI / 2, M_PI / 360, NAN);
  ASSERT_NE(rep.geometry_error, nullptr);
  EXPECT_EQ(p.counters().inconsistent_scans, 4u);
  EXPECT_EQ(p.ekf().numLandmarks(), 1u);
  EXPECT_DOUBLE_EQ(p.time(), 0.5);  // still predicted
  EXPECT_TRUE(stateFinite(p));
}

TEST(SlamPipeline, NonFiniteObservationsAreDropped) {
  auto a = everythingNew();
  SlamPipeline p(PipelineConfig(), a);
  std::vector<Observation> obs(5);
  obs[0].z = Eigen::Vector2d(5.0, 0.1);
  obs[1].z = Eigen::Vector2d(NAN, 0.1);
  obs[2].z = Eigen::Vector2d(5.0, INFINITY);
  obs[3].z = Eigen::Vector2d(6.0, 0.2);
  obs[3].R(0, 0) = NAN;
  obs[4].z = Eigen::Vector2d(7.0, -0.2);
  obs[4].R.setZero();  // default R
  const ScanReport r = p.processObservations(1.0, obs);
  EXPECT_EQ(r.invalid_observations, 3);
  EXPECT_EQ(p.counters().invalid_observations, 3u);
  ASSERT_EQ(r.observations.size(), 2u);
  EXPECT_DOUBLE_EQ(r.observations[1].R(1, 1), std::pow(p.config().sigma_bearing, 2));
  EXPECT_EQ(p.ekf().numLandmarks(), 2u);
  EXPECT_EQ(p.counters().scans_before_odometry, 1u);
  EXPECT_TRUE(stateFinite(p));
}

// --- landmark life cycle -----------------------------------------------------------------------

TEST(SlamPipeline, NewLandmarksGetIdsReportedAndAssociatorIsTold) {
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(PipelineConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  const Eigen::Vector3d pose(0, 0, 0);
  ScanReport r =
      p.processObservations(0.0, {observe(m, pose, {5, 1}, 7), observe(m, pose, {8, -2}, 9)});
  ASSERT_EQ(r.association.decision.size(), 2u);
  EXPECT_EQ(r.association.decision[0], Decision::kNew);
  const LandmarkId id0 = r.association.landmark[0], id1 = r.association.landmark[1];
  EXPECT_NE(id0, kNoLandmark);
  EXPECT_NE(id0, id1);
  EXPECT_TRUE(p.ekf().contains(id0));
  EXPECT_TRUE(p.ekf().contains(id1));
  ASSERT_EQ(oracle->added.size(), 2u);
  EXPECT_EQ(oracle->added[0], std::make_pair(0, id0));
  EXPECT_EQ(oracle->added[1], std::make_pair(1, id1));
  EXPECT_LT((p.ekf().landmark(p.ekf().indexOf(id1)) - Eigen::Vector2d(8, -2)).norm(), 1e-9);
  // Seen again: paired with the same ids.
  r = p.processObservations(0.1, {observe(m, pose, {8, -2}, 9)});
  EXPECT_EQ(r.association.decision[0], Decision::kPaired);
  EXPECT_EQ(r.association.landmark[0], id1);
  EXPECT_EQ(p.landmarkInfo(id1).times_observed, 2u);
  EXPECT_EQ(r.nis_dof, 2);
}

TEST(SlamPipeline, AssociatorRemoveListDeletesLandmarks) {
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(PipelineConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  const Eigen::Vector3d pose(0, 0, 0);
  p.processObservations(0.0, {observe(m, pose, {5, 1}, 1), observe(m, pose, {8, -2}, 2),
                              observe(m, pose, {9, 4}, 3)});
  const LandmarkId victim = oracle->id_of.at(2);
  oracle->script_ = [victim](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    r.remove = {victim};
    return r;
  };
  const ScanReport r = p.processObservations(0.1, {});
  EXPECT_EQ(r.removed, std::vector<LandmarkId>({victim}));
  EXPECT_FALSE(p.ekf().contains(victim));
  EXPECT_EQ(p.ekf().numLandmarks(), 2u);
  EXPECT_EQ(p.landmarkInfo(victim).times_observed, 0u);
}

TEST(SlamPipeline, BadAssociatorResultsAreFixedUpAndCounted) {
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(PipelineConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  const Eigen::Vector3d pose(0, 0, 0);
  p.processObservations(0.0, {observe(m, pose, {5, 1}, 1)});
  const Eigen::VectorXd before = p.ekf().mean();

  // Wrong sizes.
  oracle->script_ = [](const AssociationContext&) {
    AssociationResult r;
    r.resize(1);
    r.decision[0] = Decision::kNew;
    return r;
  };
  ScanReport r =
      p.processObservations(0.1, {observe(m, pose, {5, 1}, 1), observe(m, pose, {6, 1}, 2)});
  EXPECT_GT(r.invalid_decisions, 0);
  EXPECT_EQ(r.association.decision, std::vector<Decision>(2, Decision::kRejected));
  // Unknown ids paired and removed.
  oracle->script_ = [](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    r.pair(0, 12345);
    r.remove = {999};
    return r;
  };
  r = p.processObservations(0.2, {observe(m, pose, {5, 1}, 1)});
  EXPECT_EQ(r.invalid_decisions, 2);
  EXPECT_EQ(r.association.decision[0], Decision::kRejected);
  EXPECT_TRUE(r.removed.empty());
  EXPECT_EQ(p.counters().invalid_associations, 2u);
  EXPECT_EQ(p.ekf().numLandmarks(), 1u);
  EXPECT_TRUE(p.ekf().mean().isApprox(before));
}

TEST(SlamPipeline, ResetRestoresTheInitialStateAndResetsTheAssociator) {
  PipelineConfig c;
  c.initial_pose = Eigen::Vector3d(1, 2, 0.3);
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(c, oracle);
  p.addOdometry(odom(0.0, 1.0, 0.0));
  p.processObservations(1.0, {observe(p.observationModel(), p.pose(), {5, 1}, 1)});
  const int resets = oracle->resets;
  p.reset();
  EXPECT_EQ(oracle->resets, resets + 1);
  EXPECT_EQ(p.ekf().numLandmarks(), 0u);
  EXPECT_TRUE(p.pose().isApprox(c.initial_pose));
  EXPECT_TRUE(std::isnan(p.time()));
  EXPECT_EQ(p.counters().resets, 1u);
  EXPECT_EQ(p.counters().scans, 1u);  // counters describe the whole run
  // A new timeline starts anywhere, earlier included.
  EXPECT_TRUE(p.addOdometry(odom(0.0, 1.0, 0.0)));
}

// --- map files ---------------------------------------------------------------------------------

std::string tempPath(const std::string& name) {
  return testing::TempDir() + "ekf_slam_" + name + "_" + std::to_string(::getpid());
}

TEST(SlamPipeline, SaveLoadRoundTrip) {
  std::mt19937 rng(5);
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(smallNoiseConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  p.addOdometry(odom(0.0, 1.0, 0.05));
  for (int k = 1; k <= 5; ++k) {
    p.addOdometry(odom(0.2 * k, 1.0, 0.05));
    std::vector<Observation> obs;
    for (int j = 0; j < 4; ++j)
      obs.push_back(
          observe(m, p.pose(), Eigen::Vector2d(5 + 3 * j, -4 + 2.5 * j), j, &rng, 0.1, 0.01));
    p.processObservations(0.2 * k, obs);
  }
  // A removal leaves a gap in the ids, which must survive the round trip.
  const LandmarkId gone = oracle->id_of.at(1);
  oracle->script_ = [gone](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    r.remove = {gone};
    return r;
  };
  p.processObservations(1.1, {});
  ASSERT_EQ(p.ekf().numLandmarks(), 3u);

  const std::string path = tempPath("map");
  p.saveMap(path);
  auto other_assoc = std::make_shared<ScriptedAssociator>();
  SlamPipeline q(PipelineConfig(), other_assoc);
  q.loadMap(path, true);
  EXPECT_EQ(other_assoc->resets, 2);  // construction + load
  ASSERT_EQ(q.ekf().landmarkIds(), p.ekf().landmarkIds());
  for (std::size_t k = 0; k < 3; ++k) {
    const LandmarkId id = p.ekf().landmarkIds()[k];
    const int i = static_cast<int>(k);
    EXPECT_EQ(q.ekf().landmark(i), p.ekf().landmark(i)) << id;  // exact: %.17g
    EXPECT_EQ(q.ekf().landmarkCovariance(i), p.ekf().landmarkCovariance(i)) << id;
    EXPECT_EQ(q.landmarkInfo(id).times_observed, p.landmarkInfo(id).times_observed);
    EXPECT_EQ(q.landmarkInfo(id).diameter, p.landmarkInfo(id).diameter);
  }
  EXPECT_TRUE(q.pose().isZero());
  // New landmarks after a load do not reuse loaded ids.
  auto a = std::make_shared<ScriptedAssociator>([](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    r.decision[0] = Decision::kNew;
    return r;
  });
  SlamPipeline s(PipelineConfig(), a);
  s.loadMap(path, false);
  const ScanReport r = s.processObservations(0.0, {observe(m, s.pose(), {30, 30}, 0)});
  EXPECT_GT(r.association.landmark[0], p.ekf().landmarkIds().back());
  std::remove(path.c_str());
}

// An associator that records landmarkLoaded() calls.
class LoadRecorder : public ScriptedAssociator {
 public:
  using ScriptedAssociator::ScriptedAssociator;
  void landmarkLoaded(LandmarkId id, std::uint32_t times) override { loaded[id] = times; }
  std::map<LandmarkId, std::uint32_t> loaded;
};

TEST(SlamPipeline, LoadMapTellsTheAssociatorHowOftenEachLandmarkWasSeen) {
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(PipelineConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  const Eigen::Vector3d pose(0, 0, 0);
  for (int k = 0; k < 3; ++k) {
    std::vector<Observation> obs = {observe(m, pose, {5, 1}, 1)};
    if (k == 0) obs.push_back(observe(m, pose, {8, -2}, 2));
    p.processObservations(0.1 * k, obs);
  }
  const std::string path = tempPath("map_loaded");
  p.saveMap(path);
  auto rec = std::make_shared<LoadRecorder>();
  SlamPipeline q(PipelineConfig(), rec);
  q.loadMap(path, true);
  std::remove(path.c_str());
  EXPECT_EQ(rec->loaded, (std::map<LandmarkId, std::uint32_t>{{oracle->id_of.at(1), 3u},
                                                              {oracle->id_of.at(2), 1u}}));
}

TEST(SlamPipeline, LocalizationModeUsesTheMapButNeverChangesIt) {
  // Build a map, save it, load it in localization mode.
  auto oracle = std::make_shared<OracleAssociator>();
  SlamPipeline p(PipelineConfig(), oracle);
  const RangeBearingModel& m = p.observationModel();
  const Eigen::Vector3d pose(0, 0, 0);
  p.processObservations(0.0, {observe(m, pose, {5, 1}, 1), observe(m, pose, {8, -2}, 2)});
  const std::string path = tempPath("map_localization");
  p.saveMap(path);

  PipelineConfig config;
  config.mode = "localization";
  auto script = std::make_shared<ScriptedAssociator>();
  SlamPipeline q(config, script);
  EXPECT_TRUE(q.mapFrozen());
  q.loadMap(path, true);
  std::remove(path.c_str());
  const std::vector<LandmarkId> ids = q.ekf().landmarkIds();
  const Eigen::Vector2d before = q.ekf().landmark(0);
  // The associator pairs the first, wants a new landmark for the second, and a removal.
  script->script_ = [&](const AssociationContext& ctx) {
    AssociationResult r;
    r.resize(ctx.numObservations());
    r.pair(0, ids[0]);
    r.decision[1] = Decision::kNew;
    r.remove = {ids[1]};
    return r;
  };
  const ScanReport r = q.processObservations(
      0.1,
      {observe(m, pose, before + Eigen::Vector2d(0.05, 0.0), 1), observe(m, pose, {20, 3}, 5)});
  EXPECT_EQ(q.ekf().landmarkIds(), ids) << "the map changed";
  EXPECT_EQ(r.association.decision[0], Decision::kPaired);
  EXPECT_EQ(r.association.decision[1], Decision::kRejected);
  EXPECT_TRUE(r.removed.empty());
  EXPECT_EQ(q.counters().frozen_new, 1u);
  EXPECT_EQ(q.counters().frozen_removals, 1u);
  EXPECT_GT(r.nis_dof, 0) << "the pairing was not used";
}

TEST(SlamPipeline, ModeIsValidated) {
  MapParameterSource params;
  params.set("mode", "mapping");
  EXPECT_THROW(readPipelineConfig(params), ParameterError);
  params.set("mode", "localization");
  EXPECT_EQ(readPipelineConfig(params).mode, "localization");
}

TEST(SlamPipeline, MalformedMapFileNamesFileAndLine) {
  const std::string path = tempPath("bad_map");
  auto expectError = [&](const std::string& content, const std::string& needle) {
    {
      std::ofstream out(path);
      out << content;
    }
    SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
    try {
      p.loadMap(path, false);
      ADD_FAILURE() << "accepted:\n" << content;
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  };
  expectError("ekf_slam_map 1\n# comment\n0 1 2 0.1 0 0.1 0.3 4\n1 1 2 0.1 0 0.1 oops 4\n",
              "line 4: bad diameter");
  expectError("landmarks\n", "line 1");
  expectError("ekf_slam_map 1\n0 1 2 0.1 0 0.1 0.3\n", "line 2: expected 8 fields");
  expectError("ekf_slam_map 1\n0 1 2 0.1 0.5 0.1 0.3 1\n", "line 2: covariance");
  expectError("ekf_slam_map 1\n0 1 2 0.1 0 0.1 nan 1\n\n0 1 2 0.1 0 0.1 nan 1\n",
              "line 4: duplicate id 0 (first on line 2)");
  expectError("ekf_slam_map 1\n0 nan 2 0.1 0 0.1 nan 1\n", "line 2: bad x");
  std::remove(path.c_str());
  SlamPipeline p(PipelineConfig(), std::make_shared<ScriptedAssociator>());
  EXPECT_THROW(p.loadMap("/nonexistent/map.txt", false), std::runtime_error);
}

// --- with the real default associator ----------------------------------------------------------

TEST(SlamPipeline, RunsWithDJNN) {
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource());
  PipelineConfig c = smallNoiseConfig();
  SlamPipeline p(c, djnn);
  const std::vector<Eigen::Vector2d> marks = {{10, 3}, {12, -4}, {18, 6}, {20, -1}};
  std::mt19937 rng(9);
  const TwistModel exact;
  Eigen::Vector3d truth = c.initial_pose;
  for (int k = 0; k < 200; ++k) {
    p.addOdometry(odom(k * 0.025, 0.5, 0.0));
    if (k % 10 == 0) {
      std::vector<Observation> obs;
      for (int j = 0; j < 4; ++j)
        obs.push_back(observe(p.observationModel(), truth, marks[j], j, &rng, 0.05, 0.005));
      p.processObservations(k * 0.025, obs);
    }
    truth = exact.predict(truth, {0.5, 0.0}, 0.025);
  }
  EXPECT_EQ(p.ekf().numLandmarks(), 4u);  // each admitted once, after two sightings
  EXPECT_TRUE(stateFinite(p));
}

}  // namespace test_slam_pipeline
}  // namespace ekf_slam
