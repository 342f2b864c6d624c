// Lost-robot recovery through SlamPipeline with DJNN and FGCBB: a forced relocalisation, a
// kidnap detected by the lost rule and recovered without duplicating the map, localisation in a
// saved map from an unknown pose, the map frozen while lost, and a kidnapped simulated world end
// to end (runSimulation, as `evaluate --relocaliser` runs it), and a kidnap only a probe can see.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "relocalisation_fixtures.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_recovery {

using reloc_test::World;

// A robot driving through an irregular forest, seen by a 360-degree 15 m sensor, with exact
// odometry; the truth can be kidnapped (the odometry does not notice).
class Drive {
 public:
  explicit Drive(bool relocaliser = true, const Eigen::Vector3d& start = {20, 30, 0.1},
                 std::shared_ptr<Relocaliser> custom = nullptr, int confirmations = 0,
                 int held_fixes = 1, double confirm_probability = 0.0,
                 const std::function<void(PipelineConfig*)>& tune = {})
      : world_(reloc_test::randomMap(250, 120.0, 3.0, 21)), truth_(start) {
    config_.initial_pose = start;
    config_.initial_pose_sigma = Eigen::Vector3d(0.01, 0.01, 0.001);
    config_.sigma_range = reloc_test::kSigmaRange;
    config_.sigma_bearing = reloc_test::kSigmaBearing;
    config_.max_observation_range = 15.0;
    config_.lost_field_of_view = 2.0 * M_PI;
    config_.relocalisation_confirmations = confirmations;
    config_.relocalisation_held_fixes = held_fixes;
    config_.relocalisation_confirm_probability = confirm_probability;
    config_.twist.additive = Eigen::Vector3d(0.005, 0.005, 0.0005).asDiagonal();
    if (tune) tune(&config_);
    djnn_ = std::make_shared<DJNN>();
    MapParameterSource djnn_params;
    djnn_params.set("sensor_range", "15");
    djnn_params.set("field_of_view", "6.2831");
    djnn_->configure(djnn_params);
    pipeline_ = std::make_unique<SlamPipeline>(config_, djnn_);
    pipeline_->setSensorOffset(world_.sensor_offset);
    if (custom) {
      pipeline_->setRelocaliser(custom);
    } else if (relocaliser) {
      pipeline_->setRelocaliser(std::make_shared<FGCBB>());
    }
  }

  /// `scans` scans at 5 Hz driving at 2 m/s with a gentle turn; returns the last report.
  ScanReport run(int scans, double w = 0.05) {
    ScanReport last;
    const TwistModel exact;
    for (int k = 0; k < scans; ++k) {
      for (int s = 0; s < 8; ++s) {
        pipeline_->addOdometry(odom(w));
        truth_ = exact.predict(truth_, {2.0, w}, 0.025);
        t_ += 0.025;
      }
      last =
          pipeline_->processObservations(t_, world_.observe(truth_, 15.0, nullptr, true, seed_++));
      reports_.push_back(last);
    }
    return last;
  }
  void kidnap(const Eigen::Vector3d& jump) {
    truth_ += jump;
    truth_.z() = wrapAngle(truth_.z());
  }
  double error() const { return (pipeline_->pose().head<2>() - truth_.head<2>()).norm(); }
  double headingError() const { return std::abs(wrapAngle(pipeline_->pose().z() - truth_.z())); }
  /// Landmarks with no tree of the world within 1 m: mapped at a wrong pose.
  int misplaced() const {
    const EkfSlam& ekf = pipeline_->ekf();
    int n = 0;
    for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
      bool near = false;
      for (const MapLandmark& l : world_.map)
        near = near || (ekf.landmark(static_cast<int>(k)) - l.position).norm() < 1.0;
      n += !near;
    }
    return n;
  }
  /// Pairs of landmarks closer than 1 m: a landmark mapped twice.
  int duplicates() const {
    const EkfSlam& ekf = pipeline_->ekf();
    int d = 0;
    for (std::size_t a = 0; a < ekf.numLandmarks(); ++a)
      for (std::size_t b = a + 1; b < ekf.numLandmarks(); ++b)
        d += (ekf.landmark(static_cast<int>(a)) - ekf.landmark(static_cast<int>(b))).norm() < 1.0;
    return d;
  }

  SlamPipeline& pipeline() { return *pipeline_; }
  const Eigen::Vector3d& truth() const { return truth_; }
  std::vector<ScanReport>& reports() { return reports_; }
  PipelineConfig config_;

 private:
  OdometryInput odom(double w) const {
    OdometryInput o;
    o.stamp = t_;
    o.twist = Eigen::Vector2d(2.0, w);
    return o;
  }

  World world_;
  Eigen::Vector3d truth_;
  double t_ = 0.0;
  unsigned seed_ = 1;
  std::shared_ptr<DJNN> djnn_;
  std::unique_ptr<SlamPipeline> pipeline_;
  std::vector<ScanReport> reports_;
};

TEST(Recovery, ForcedRelocalisationReplacesThePoseConsistently) {
  Drive d;
  d.run(40);
  ASSERT_LT(d.error(), 0.3);
  const std::size_t landmarks = d.pipeline().ekf().numLandmarks();
  ASSERT_GT(landmarks, 10u);
  ASSERT_TRUE(d.pipeline().requestRelocalisation());
  EXPECT_TRUE(d.pipeline().lost());
  const ScanReport r = d.run(1);
  EXPECT_TRUE(r.lost);
  ASSERT_TRUE(r.relocalised) << r.relocalisation.reason;
  EXPECT_FALSE(d.pipeline().lost());
  EXPECT_LT(d.error(), 0.3);
  EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
  EXPECT_EQ(d.pipeline().counters().relocalisation_requests, 1u);
  // Every relocaliser pairing went into the update; nothing was added or removed.
  int paired = 0;
  for (const Decision x : r.association.decision) paired += x == Decision::kPaired;
  EXPECT_EQ(paired, r.relocalisation.hypothesis_size);
  EXPECT_EQ(d.pipeline().ekf().numLandmarks(), landmarks);
  // The pose is correlated with the map again (re-derived from it) and its covariance is sane:
  // NEES of the pose below chi2(3, 0.999) = 16.3.
  const Eigen::Vector3d e(d.pipeline().pose().x() - d.truth().x(),
                          d.pipeline().pose().y() - d.truth().y(),
                          wrapAngle(d.pipeline().pose().z() - d.truth().z()));
  EXPECT_LT(e.dot(d.pipeline().poseCovariance().ldlt().solve(e)), 16.3);
  EXPECT_GT(d.pipeline().ekf().covariance().block(0, 3, 3, 2 * landmarks).cwiseAbs().maxCoeff(),
            1e-6);
  // Tracking goes on.
  d.run(20);
  EXPECT_LT(d.error(), 0.3);
  EXPECT_FALSE(d.pipeline().lost());
}

TEST(Recovery, KidnapIsDetectedAndRecoveredWithoutDuplicatingTheMap) {
  Drive d;
  d.run(50);
  ASSERT_LT(d.error(), 0.3);
  const std::size_t landmarks = d.pipeline().ekf().numLandmarks();
  d.kidnap({-12.0, -2.0, 1.2});  // back into the mapped part of the forest, turned
  int recovered_after = -1;
  for (int k = 0; k < 15 && recovered_after < 0; ++k) {
    const ScanReport r = d.run(1);
    if (r.relocalised) recovered_after = k;
    if (r.relocalisation_attempted && !r.relocalised) {
      EXPECT_NE(r.relocalisation.reason, "");
    }
  }
  ASSERT_GE(recovered_after, 0) << "not recovered";
  EXPECT_LE(recovered_after, 5);  // lost after 3 scans, found at the next ones
  EXPECT_LT(d.error(), 0.5);
  EXPECT_LT(d.headingError(), 0.02);
  EXPECT_EQ(d.pipeline().counters().lost_events, 1u);
  EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
  // Landmarks created from the wrong pose before the rule fired were discarded.
  EXPECT_LE(d.pipeline().ekf().numLandmarks(), landmarks + 2);
  d.run(40);
  EXPECT_LT(d.error(), 0.5);
  EXPECT_EQ(d.duplicates(), 0);
}

// The probe (docs/relocalisation.md, rule 1's probe): the filter believes it stands in ground it
// has not mapped, while the vehicle is back in the mapped part of the forest. No lost rule can fire
// (no established landmark in view at the believed pose), so the relocaliser probes; its fix lies
// far outside the filter's estimate, so the pipeline goes lost and applies it (with
// relocalisation_confirmations 1, once the next fix agrees). Landmarks mapped at the believed pose
// meanwhile are discarded.
TEST(Recovery, AProbeFindsAKidnapIntoGroundTheFilterTakesForNew) {
  test_files::TempDir dir;
  const std::string path = (dir.path() / "map.txt").string();
  const Eigen::Vector3d mapped_start(20.0, 30.0, 0.1);
  {
    Drive d(true, mapped_start);
    d.run(60);
    d.pipeline().saveMap(path);
  }
  for (const int confirmations : {0, 1}) {
    SCOPED_TRACE("relocalisation_confirmations " + std::to_string(confirmations));
    const Eigen::Vector3d believed(100.0, 100.0, -2.0);  // far from every mapped landmark
    Drive d(true, believed, nullptr, confirmations);
    d.pipeline().loadMap(path, /*reset_pose=*/false, /*unknown_pose=*/false);
    ASSERT_FALSE(d.pipeline().lost());
    const std::size_t loaded = d.pipeline().ekf().numLandmarks();
    d.kidnap(mapped_start - believed + Eigen::Vector3d(4.0, 1.0, 0.0));
    int relocalised_at = -1;
    for (int k = 0; k < 20 && relocalised_at < 0; ++k) {
      if (d.run(1).relocalised) relocalised_at = k;
    }
    ASSERT_GE(relocalised_at, 0) << "never relocalised";
    EXPECT_GT(d.pipeline().counters().probes, 0u);
    EXPECT_EQ(d.pipeline().counters().lost_events, 1u);
    EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
    EXPECT_EQ(d.pipeline().counters().relocalisations_unconfirmed,
              static_cast<std::uint64_t>(confirmations));
    EXPECT_LT(d.error(), 0.5);
    EXPECT_LT(d.headingError(), 0.02);
    // What was mapped at the believed pose is gone; the saved map is kept, not duplicated.
    EXPECT_EQ(d.pipeline().ekf().numLandmarks(), loaded);
    d.run(20);
    EXPECT_LT(d.error(), 0.5);
    EXPECT_EQ(d.duplicates(), 0);
  }
}

// Never finds anything; counts its calls and remembers the map it was given.
class NeverFound : public Relocaliser {
 public:
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "NeverFound"; }
  void setMap(const std::vector<MapLandmark>& map) override { map_size = map.size(); }
  RelocalisationResult relocalise(const std::vector<Observation>& obs, const Eigen::Vector3d&,
                                  const PosePrior* prior) override {
    ++calls;
    EXPECT_EQ(prior, nullptr);  // recovery is global
    RelocalisationResult r;
    r.landmark.assign(obs.size(), kNoLandmark);
    r.reason = "never";
    return r;
  }
  std::size_t map_size = 0;
  int calls = 0;
};

// Found at every call: a pose 30 m off at the calls listed (default the first), the truth at
// the others (chance alignments, and the right place).
class WrongThenRight : public Relocaliser {
 public:
  explicit WrongThenRight(const Eigen::Vector3d* truth, std::vector<int> wrong = {0},
                          const Eigen::Vector3d& offset = {30.0, -20.0, 1.0})
      : truth_(truth), wrong_(std::move(wrong)), offset_(offset) {}
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "WrongThenRight"; }
  void setMap(const std::vector<MapLandmark>&) override {}
  RelocalisationResult relocalise(const std::vector<Observation>& obs, const Eigen::Vector3d&,
                                  const PosePrior*) override {
    RelocalisationResult r;
    r.landmark.assign(obs.size(), kNoLandmark);
    r.status = RelocalisationStatus::kFound;
    const bool wrong = std::find(wrong_.begin(), wrong_.end(), calls++) != wrong_.end();
    r.pose = *truth_ + (wrong ? offset_ : Eigen::Vector3d::Zero());
    r.covariance = 1e-4 * Eigen::Matrix3d::Identity();
    return r;
  }
  int calls = 0;

 private:
  const Eigen::Vector3d* truth_;
  std::vector<int> wrong_;
  Eigen::Vector3d offset_;
};

TEST(Recovery, AFixIsAppliedOnlyOnceTheNextAgrees) {
  for (const int confirmations : {0, 1}) {
    SCOPED_TRACE("relocalisation_confirmations " + std::to_string(confirmations));
    Drive d(true, {20, 30, 0.1}, nullptr, confirmations);
    auto reloc = std::make_shared<WrongThenRight>(&d.truth());
    d.pipeline().setRelocaliser(reloc);
    d.run(20);
    ASSERT_TRUE(d.pipeline().requestRelocalisation());
    const ScanReport first = d.run(1);
    if (confirmations == 0) {  // the chance alignment is taken: 30 m off
      EXPECT_TRUE(first.relocalised);
      EXPECT_GT(d.error(), 20.0);
      continue;
    }
    EXPECT_FALSE(first.relocalised);  // held
    EXPECT_TRUE(d.pipeline().lost());
    const ScanReport second = d.run(1);  // the truth, 36 m from the held fix: held instead
    EXPECT_FALSE(second.relocalised);
    const ScanReport third = d.run(1);  // the truth again, moved by the odometry: applied
    EXPECT_TRUE(third.relocalised) << third.lost_reason;
    EXPECT_FALSE(d.pipeline().lost());
    EXPECT_LT(d.error(), 0.5);
    EXPECT_EQ(reloc->calls, 3);
    EXPECT_EQ(d.pipeline().counters().relocalisations_unconfirmed, 2u);
    EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
  }
}

// The right place, a chance alignment elsewhere, the right place again: with one held fix the
// chance alignment replaced the first, and the third only starts again; with two the third
// confirms the first (moved by the odometry) past the chance alignment.
TEST(Recovery, ALaterFixConfirmsAnEarlierHeldOneWithSeveralHeld) {
  for (const int held : {1, 2}) {
    SCOPED_TRACE("relocalisation_held_fixes " + std::to_string(held));
    Drive d(true, {20, 30, 0.1}, nullptr, /*confirmations=*/1, held);
    auto reloc = std::make_shared<WrongThenRight>(&d.truth(), std::vector<int>{1});
    d.pipeline().setRelocaliser(reloc);
    d.run(20);
    ASSERT_TRUE(d.pipeline().requestRelocalisation());
    EXPECT_FALSE(d.run(1).relocalised);  // right: held
    EXPECT_FALSE(d.run(1).relocalised);  // the chance alignment 36 m away: held as well
    const ScanReport third = d.run(1);   // right again
    EXPECT_EQ(third.relocalised, held == 2) << third.lost_reason;
    EXPECT_EQ(d.pipeline().lost(), held == 1);
    if (held == 2) {
      EXPECT_LT(d.error(), 0.5);
      EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
    }
  }
}

// relocalisation_confirm_probability: two fixes 1 m apart, each to 1 cm, with exact odometry
// between them agree within the fixed 2 m, not by the chi2 test on their covariances.
TEST(Recovery, TheChi2ComparisonUsesTheFixesCovariances) {
  for (const double probability : {0.0, 0.999}) {
    SCOPED_TRACE("relocalisation_confirm_probability " + std::to_string(probability));
    Drive d(true, {20, 30, 0.1}, nullptr, /*confirmations=*/1, /*held_fixes=*/1, probability);
    auto reloc = std::make_shared<WrongThenRight>(&d.truth(), std::vector<int>{1},
                                                  Eigen::Vector3d(1.0, 0.0, 0.0));
    d.pipeline().setRelocaliser(reloc);
    d.run(20);
    ASSERT_TRUE(d.pipeline().requestRelocalisation());
    EXPECT_FALSE(d.run(1).relocalised);                   // the truth: held
    EXPECT_EQ(d.run(1).relocalised, probability == 0.0);  // 1 m off
    if (probability == 0.0) continue;
    EXPECT_FALSE(d.run(1).relocalised);  // the truth, 1 m from the held fix: held instead
    EXPECT_TRUE(d.run(1).relocalised);   // and confirmed by the next
    EXPECT_LT(d.error(), 0.5);
  }
}

TEST(Recovery, MapIsFrozenWhileLost) {
  auto never = std::make_shared<NeverFound>();
  Drive d(true, {20, 30, 0.1}, never);
  d.run(30);
  const std::size_t landmarks = d.pipeline().ekf().numLandmarks();
  const int first = d.pipeline().ekf().stateRow(0);
  const Eigen::VectorXd map = d.pipeline().ekf().mean().segment(first, 2 * landmarks);
  ASSERT_TRUE(d.pipeline().requestRelocalisation());
  EXPECT_EQ(never->map_size, landmarks);
  for (int k = 0; k < 20; ++k) {  // on into unmapped forest: nothing is added while lost
    const ScanReport r = d.run(1);
    EXPECT_TRUE(r.lost);
    EXPECT_FALSE(r.relocalised);
    EXPECT_TRUE(r.removed.empty());
    EXPECT_EQ(r.association.decision.size(), r.observations.size());
    for (const Decision x : r.association.decision) EXPECT_EQ(x, Decision::kRejected);
  }
  EXPECT_EQ(never->calls, 20);
  EXPECT_TRUE(d.pipeline().lost());
  EXPECT_EQ(d.pipeline().counters().relocalisations_not_found, 20u);
  EXPECT_EQ(d.pipeline().ekf().numLandmarks(), landmarks);
  EXPECT_TRUE(d.pipeline().ekf().mean().segment(first, 2 * landmarks).isApprox(map));
  EXPECT_EQ(d.pipeline().counters().relocalisation_attempts, 20u);
  EXPECT_EQ(d.pipeline().counters().relocalisations, 0u);
  // reset() ends it.
  d.pipeline().reset();
  EXPECT_FALSE(d.pipeline().lost());
}

// The relocaliser replaced by one that finds the truth; the next scan's report.
ScanReport fixAtTheTruth(Drive& d) {
  d.pipeline().setRelocaliser(std::make_shared<WrongThenRight>(&d.truth(), std::vector<int>{}));
  return d.run(1);
}

// Re-derived pose k is that of scans[k + skip], within 15 cm and 20 mrad of truths[k + skip]: the
// odometry here is exact, and the lost scans' poses are the mapping's estimates, which carry the
// noise of their pairings (with a real odometry's drift they are the better ones).
void expectWhereTheVehicleWas(const std::vector<LostPathPose>& path,
                              const std::vector<std::uint32_t>& scans,
                              const std::vector<Eigen::Vector3d>& truths, std::size_t skip) {
  for (std::size_t k = 0; k < path.size(); ++k) {
    EXPECT_EQ(path[k].scan, scans[k + skip]);
    EXPECT_LT((path[k].pose.head<2>() - truths[k + skip].head<2>()).norm(), 0.15) << k;
    EXPECT_LT(std::abs(wrapAngle(path[k].pose.z() - truths[k + skip].z())), 2e-2) << k;
  }
}

// While lost the estimate is dead-reckoned from the wrong pose; once relocalised, each lost
// scan's pose is carried back from the fix by the odometry between them: where the vehicle was.
TEST(Recovery, TheLostPathIsReDerivedFromTheFix) {
  auto never = std::make_shared<NeverFound>();
  Drive d(true, {20, 30, 0.1}, never);
  d.run(30);
  d.pipeline().injectPoseJump({8.0, -5.0, 1.5});  // the estimate jumps, not the vehicle
  ASSERT_TRUE(d.pipeline().requestRelocalisation());
  std::vector<Eigen::Vector3d> truths;
  std::vector<std::uint32_t> scans;
  for (int k = 0; k < 15; ++k) {
    const ScanReport r = d.run(1);
    ASSERT_TRUE(r.lost);
    EXPECT_TRUE(r.lost_path.empty());
    EXPECT_GT(d.headingError(), 1.0);  // dead-reckoned from the jumped pose
    truths.push_back(d.truth());
    scans.push_back(r.scan);
  }
  const ScanReport fixed = fixAtTheTruth(d);
  ASSERT_TRUE(fixed.relocalised);
  ASSERT_EQ(fixed.lost_path.size(), truths.size());
  expectWhereTheVehicleWas(fixed.lost_path, scans, truths, 0);
  EXPECT_EQ(d.pipeline().counters().lost_path_poses, truths.size());
  EXPECT_TRUE(d.run(1).lost_path.empty());  // tracking: nothing to re-derive
}

// A kidnap seen late: the estimate jumps, the pipeline tracks three scans at the wrong pose before
// it goes lost. At the fix those three are carried back by the odometry as well (`tracked`), the
// lost scans after them as before, and no scan from before the jump (its estimate agrees with the
// fix carried back). Without a jump a forced relocalisation re-derives no tracked scan.
TEST(Recovery, TheTrackedScansBeforeGoingLostAreReDerivedWhenTheFixContradictsThem) {
  for (const bool jump : {true, false}) {
    SCOPED_TRACE(jump ? "jump" : "no jump");
    auto never = std::make_shared<NeverFound>();
    Drive d(true, {20, 30, 0.1}, never);
    d.run(30);
    if (jump) d.pipeline().injectPoseJump({8.0, -5.0, 1.5});  // the estimate, not the vehicle
    std::vector<Eigen::Vector3d> truths;
    std::vector<std::uint32_t> scans;
    std::size_t tracked_after_jump = 0;
    for (int k = 0; k < 3; ++k) {
      const ScanReport r = d.run(1);
      truths.push_back(d.truth());
      scans.push_back(r.scan);
      tracked_after_jump += !r.lost && !r.became_lost;
    }
    if (!d.pipeline().lost()) {
      ASSERT_TRUE(d.pipeline().requestRelocalisation());
    }
    for (int k = 0; k < 5; ++k) {
      const ScanReport r = d.run(1);
      ASSERT_TRUE(r.lost);
      truths.push_back(d.truth());
      scans.push_back(r.scan);
    }
    const ScanReport fixed = fixAtTheTruth(d);
    ASSERT_TRUE(fixed.relocalised);
    const std::size_t expected_tracked = jump ? tracked_after_jump : 0;
    EXPECT_EQ(d.pipeline().counters().rederived_tracked_poses, expected_tracked);
    // Tracked scans not re-derived (none lost among the first three without a jump).
    const std::size_t skip = jump ? 0 : 3;
    ASSERT_EQ(fixed.lost_path.size(), truths.size() - skip);
    expectWhereTheVehicleWas(fixed.lost_path, scans, truths, skip);
    for (std::size_t k = 0; k < fixed.lost_path.size(); ++k)
      EXPECT_EQ(fixed.lost_path[k].tracked, k < expected_tracked) << k;
    if (jump) {
      EXPECT_EQ(expected_tracked, 3u);  // the jump is seen by no rule in three scans
    }
  }
}

// A kidnap no rule sees (the rules off): the estimate jumps and the filter maps an island of trees
// at the wrong pose for 40 scans, until a forced relocalisation fixes it. At the fix the onset is
// found where the jump was (KidnapOnset), the map goes back to the state kept before it and every
// scan since is mapped as a lost scan: no tree is left where none is, and tracking goes on right.
// With lost_onset_scans 0 the island stays.
TEST(Recovery, AKidnapFoundLateRollsTheMapBackToItsOnset) {
  for (const int window : {100, 0}) {  // 100: a state kept every 10 scans
    SCOPED_TRACE(window);
    Drive d(true, {20, 30, 0.1}, nullptr, 0, 1, 0.0, [window](PipelineConfig* c) {
      c->lost_unpaired_scans = 0;
      c->lost_nis_scans = 0;
      c->lost_rejected_scans = 0;
      c->lost_onset_scans = window;
    });
    d.run(40);
    ASSERT_EQ(d.misplaced(), 0);
    const std::uint32_t jump_scan = d.run(1).scan + 1;
    d.pipeline().injectPoseJump({8.0, -5.0, 1.5});  // the estimate, not the vehicle
    for (int k = 0; k < 40; ++k) EXPECT_FALSE(d.run(1).lost);
    ASSERT_GT(d.misplaced(), 5);  // the island
    ASSERT_TRUE(d.pipeline().requestRelocalisation());
    const ScanReport fixed = fixAtTheTruth(d);
    ASSERT_TRUE(fixed.relocalised);
    EXPECT_LT(d.error(), 0.3);
    if (window > 0) {
      EXPECT_EQ(d.pipeline().counters().onset_rollbacks, 1u);
      EXPECT_NEAR(static_cast<double>(fixed.onset_scan), jump_scan, 1.0);
      EXPECT_LE(fixed.onset_rolled_back_from, fixed.onset_scan);
      EXPECT_EQ(d.misplaced(), 0);
      // The scans since are re-derived, the jumped ones among them.
      ASSERT_FALSE(fixed.lost_path.empty());
      EXPECT_LE(fixed.lost_path.front().scan, jump_scan);
      d.run(20);
      EXPECT_LT(d.error(), 0.3);
      EXPECT_FALSE(d.pipeline().lost());
    } else {
      EXPECT_EQ(d.pipeline().counters().onset_rollbacks, 0u);
      EXPECT_GT(d.misplaced(), 5);  // (and the island misleads the filter after the fix)
    }
  }
}

// The caller's trajectory rows take the lost path by stamp (within 1 us); others stay.
TEST(Recovery, ApplyLostPathReplacesTheRowsOfTheLostScans) {
  const std::vector<double> stamps{1.0, 2.0, 3.0000004, 4.0, 5.0};  // 5.0: the fix's row
  std::vector<double> x(stamps.size(), 0.0);
  const std::vector<LostPathPose> path{
      {7, 0.5, {9, 0, 0}}, {8, 3.0, {3, 0, 0}}, {9, 4.0, {4, 0, 0}}};
  applyLostPath(
      path, stamps.size() - 1, [&](std::size_t i) { return stamps[i]; },
      [&](std::size_t i, const Eigen::Vector3d& p) { x[i] = p.x(); });
  EXPECT_EQ(x, (std::vector<double>{0, 0, 3, 4, 0}));
}

TEST(Recovery, SavedMapWithUnknownPoseStartsLostAndFindsItself) {
  test_files::TempDir dir;
  const std::string path = (dir.path() / "map.txt").string();
  {
    Drive d;
    d.run(60);
    d.pipeline().saveMap(path);
  }
  // A new run somewhere else on the route, its initial pose far off.
  Drive d(true, {45.0, 40.0, 2.0});
  d.pipeline().loadMap(path, /*reset_pose=*/false, /*unknown_pose=*/true);
  EXPECT_TRUE(d.pipeline().lost());
  const std::size_t landmarks = d.pipeline().ekf().numLandmarks();
  const ScanReport r = d.run(1);
  ASSERT_TRUE(r.relocalised) << r.relocalisation.reason;
  EXPECT_LT(d.error(), 0.5);
  EXPECT_EQ(d.pipeline().ekf().numLandmarks(), landmarks);
  EXPECT_EQ(d.pipeline().counters().relocalisation_requests, 1u);
}

TEST(Recovery, WithoutRelocaliserNothingChanges) {
  Drive d(false);
  EXPECT_FALSE(d.pipeline().requestRelocalisation());
  EXPECT_FALSE(d.pipeline().lost());
  d.run(10);
  d.kidnap({-15.0, 12.0, 1.2});
  d.run(10);
  EXPECT_FALSE(d.pipeline().lost());
  EXPECT_EQ(d.pipeline().counters().lost_events, 0u);
  test_files::TempDir dir;
  d.pipeline().saveMap((dir.path() / "map.txt").string());
  const std::size_t landmarks = d.pipeline().ekf().numLandmarks();
  EXPECT_THROW(d.pipeline().loadMap((dir.path() / "map.txt").string(), false, true),
               std::runtime_error);
  EXPECT_EQ(d.pipeline().ekf().numLandmarks(), landmarks);
}

TEST(Recovery, KidnappedSimulatedWorldRecoversWithinTwoSeconds) {
  const sim::World world = sim::makeWorld("rrw_kidnap_5");
  PipelineConfig config = sim::pipelineConfigFor(world);
  config.lost_field_of_view = 2.0 * M_PI;
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  auto fgcbb = std::make_shared<FGCBB>();
  fgcbb->configure(MapParameterSource(sim::associatorParametersFor(world, "FGCBB")));
  const RunMetrics m =
      runSimulation(world, world.default_seed, config, djnn, nullptr, nullptr, fgcbb);
  EXPECT_GE(m.lost_events, 1u);
  EXPECT_GE(m.relocalisations, 1u);
  EXPECT_EQ(m.wrong_relocalisations, 0u);
  ASSERT_GE(m.recovery_scans, 0) << "never recovered";
  EXPECT_LE(m.recovery_s, 2.0);
  // In its own map the fix is right (0.02 m); against the truth's frame the pose also carries
  // the map's drift, which in the rrw worlds (every landmark 100-280 m away under 3 deg x 5
  // bearing noise) is 1-2 m before any kidnap (the whole run's pose RMSE, 2.3 m).
  EXPECT_LT(m.error_after_kidnap_map_m, 0.25);
  EXPECT_LT(m.pose_rmse_after_recovery_m, 2.0);
  EXPECT_EQ(m.map.duplicates, 0u);
}

}  // namespace test_recovery
}  // namespace ekf_slam
