// Lost rule 3 of SlamPipeline (lost_rejected_scans): the associator recognised landmarks without
// the pose (RRWSC's graph matching) and the filter gate refused them, so the pose is wrong. On the
// kidnapped worlds of seed 004 with RRWSC + the RRWSC relocaliser the pipeline must go lost at the
// first scan after the kidnap, relocalise within 2 s, and create no landmark at the kidnapped
// pose; with the rule off the same runs do not (the checks can fail).
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "ekf_slam/core/association/rrwsc.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace test_refused_lost_rule {

// Seed 4: the filter is 0.23 m from the truth just before the kidnap. In seeds whose filter is
// already more than 1 m off there (the EKF's own error in this world, true associations included:
// docs/results.md), no relocalisation in that map can bring the pose under 1 m.
constexpr std::uint64_t kSeed = 4;
constexpr int kScansAfter = 10;  // 2 s at 5 Hz

struct KidnapRun {
  int kidnap_scan = -1;           // first scan after the jump
  int lost_scan = -1;             // the scan the pipeline went lost at
  double error_before = -1.0;     // position error at the scan before the kidnap [m]
  double error_after = -1.0;      // ... kScansAfter scans after it [m]
  int new_after_kidnap = 0;       // kNew decisions from the kidnap scan on
  std::size_t max_landmarks = 0;  // the largest map from the kidnap on
  std::uint64_t lost_events = 0, suppressed_new = 0;
};

KidnapRun runKidnap(const std::string& world_name, int lost_rejected_scans) {
  const sim::World world = sim::makeWorld(world_name);
  PipelineConfig config = sim::pipelineConfigFor(world);
  config.lost_rejected_scans = lost_rejected_scans;
  auto rrwsc = std::make_shared<RRWSC>();
  rrwsc->configure(MapParameterSource(sim::associatorParametersFor(world, "RRWSC")));
  auto relocaliser = std::make_shared<RRWSCRelocaliser>();
  relocaliser->configure(MapParameterSource());
  SlamPipeline pipeline(config, rrwsc);
  pipeline.setSensorOffset(world.sensor.offset);
  pipeline.setRelocaliser(relocaliser);

  KidnapRun run;
  sim::Simulation simulation(world, kSeed);
  double last_error = -1.0;
  feedSimulation(simulation, pipeline, [&](const sim::ObservationSet& set) {
    const ScanReport r =
        pipeline.processObservations(set.stamp + sim::kStampOffset, set.toObservations());
    const double error = (pipeline.pose().head<2>() - set.true_pose.head<2>()).norm();
    const int scan = static_cast<int>(r.scan);
    if (run.kidnap_scan < 0 && simulation.kidnapsApplied() > 0) {
      run.kidnap_scan = scan;
      run.error_before = last_error;
    }
    last_error = error;
    if (run.kidnap_scan < 0) return true;
    if (r.became_lost && run.lost_scan < 0) run.lost_scan = scan;
    for (const Decision d : r.association.decision) run.new_after_kidnap += d == Decision::kNew;
    run.max_landmarks = std::max(run.max_landmarks, pipeline.activeEkf().numLandmarks());
    if (scan < run.kidnap_scan + kScansAfter) return true;
    run.error_after = error;
    return false;
  });
  run.lost_events = pipeline.counters().lost_events;
  run.suppressed_new = pipeline.counters().suppressed_new;
  return run;
}

class KidnappedWorld : public testing::TestWithParam<std::string> {};

TEST_P(KidnappedWorld, RecoversAtTheFirstScanWithoutMappingTheKidnappedPose) {
  const std::string name = GetParam();
  const std::size_t true_landmarks = sim::makeWorld(name).landmarks.size();
  const KidnapRun run = runKidnap(name, 1);
  ASSERT_GE(run.kidnap_scan, 0) << "no kidnap in " << name;
  ASSERT_GE(run.error_after, 0.0) << "the run ended before 2 s after the kidnap";
  EXPECT_LT(run.error_before, 0.5);
  EXPECT_EQ(run.lost_scan, run.kidnap_scan);  // at once: the first scan after the jump
  EXPECT_EQ(run.lost_events, 1u);
  EXPECT_LT(run.error_after, 1.0);
  EXPECT_EQ(run.new_after_kidnap, 0);
  EXPECT_EQ(run.max_landmarks, true_landmarks);
}

TEST_P(KidnappedWorld, WithTheRuleOffTheKidnapIsMapped) {
  // The control: rules 1 and 2 alone leave the pose wrong 2 s later, and the scans after the jump
  // start landmarks at the kidnapped pose.
  const KidnapRun run = runKidnap(GetParam(), 0);
  ASSERT_GE(run.error_after, 0.0);
  EXPECT_NE(run.lost_scan, run.kidnap_scan);
  EXPECT_GT(run.new_after_kidnap, 0);
  EXPECT_GT(run.max_landmarks, sim::makeWorld(GetParam()).landmarks.size());
  EXPECT_EQ(run.suppressed_new, 0u);
}

// 4.6 m and 46 m (the largest). At 46 m this seed's graph matching recognises only 6 of the 40
// observations (5 refused, 1 chance pairing): the rule compares the refused with the paired ones,
// not with every observation.
INSTANTIATE_TEST_SUITE_P(Seed004, KidnappedWorld, testing::Values("rrw_kidnap_1", "rrw_kidnap_10"));

TEST(RefusedLostRule, EarlierScansOfTheStreakCreateNoLandmark) {
  // With two scans required the first refused scan is applied without its new landmarks, the
  // second goes lost.
  const KidnapRun run = runKidnap("rrw_kidnap_5", 2);
  EXPECT_EQ(run.lost_scan, run.kidnap_scan + 1);
  EXPECT_EQ(run.new_after_kidnap, 0);
  EXPECT_GT(run.suppressed_new, 0u);
  EXPECT_LT(run.error_after, 1.0);
}

TEST(RefusedLostRule, ParameterIsValidated) {
  PipelineConfig config;
  config.lost_rejected_scans = -1;
  EXPECT_THROW(config.validate(), ParameterError);
}

}  // namespace test_refused_lost_rule
}  // namespace ekf_slam
