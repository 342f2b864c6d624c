// lost_rollback: the scans tracked at a kidnapped pose before a lost rule fires are undone. A
// scripted associator plays the kidnapped filter (one chance pairing a scan, which moves the map,
// and a landmark dropped for being missed, as DJNN drops it); lost rule 4 fires after 10 scans.
// With the rollback the map is the one from before the kidnap and those scans are mapped again at
// the fix; a run that never goes lost is the run without the rollback.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lost_scene.h"

namespace ekf_slam {
namespace test_lost_rollback {

using lost_scene::kLandmarks;
using lost_scene::Scene;

// Rule 4 alone calls it lost (no probe whose fix would change the map at the same scan).
PipelineConfig rollbackConfig(bool rollback) {
  PipelineConfig config;
  config.lost_share_window = 10;
  config.lost_nis_scans = 0;
  config.lost_rollback = rollback;
  return config;
}

// Tracked, kidnapped, then lost: the map at the lost event and that before the kidnap.
struct Kidnapped {
  std::map<LandmarkId, Eigen::Vector2d> before, at_lost;
  ScanReport lost;
};

Kidnapped kidnap(Scene& s) {
  Kidnapped k;
  EXPECT_FALSE(s.run(30, -1));  // mapped, then tracked until established
  k.before = s.map();
  s.pipeline().injectPoseJump(Eigen::Vector3d(2.5, -2.0, 0.3));
  // The first kidnapped scan drops a landmark it "missed"; each scan pairs one by chance.
  s.associator().remove = {s.associator().id(kLandmarks - 1)};
  EXPECT_TRUE(s.run(12, 1));
  k.at_lost = s.map();
  k.lost = s.last();
  return k;
}

TEST(LostRollback, TheMapIsTheOneFromBeforeTheKidnap) {
  Scene s(rollbackConfig(true));
  const Kidnapped k = kidnap(s);
  EXPECT_NE(k.lost.lost_reason.find("map rolled back"), std::string::npos) << k.lost.lost_reason;
  EXPECT_GE(k.lost.rolled_back_scans, 10);
  // Every landmark as it was, the dropped one back.
  ASSERT_EQ(k.at_lost.size(), k.before.size());
  for (const auto& [id, p] : k.before) {
    ASSERT_EQ(k.at_lost.count(id), 1u) << id;
    EXPECT_LT((k.at_lost.at(id) - p).norm(), 1e-12) << id;
  }
  EXPECT_TRUE(s.pipeline().ekf().mean().allFinite());
  // The fix (FGCBB at the true pose, the origin) maps the undone scans again as lost scans.
  ScanReport fix;
  for (int i = 0; i < 5 && !fix.relocalised; ++i) {
    s.run(1, -1);
    fix = s.last();
  }
  ASSERT_TRUE(fix.relocalised);
  EXPECT_GT(fix.lost_map_pairings, 0);
  EXPECT_LT(s.pipeline().pose().head<2>().norm(), 0.1);
  for (const auto& [id, p] : k.before) EXPECT_LT((s.map().at(id) - p).norm(), 0.1) << id;
}

TEST(LostRollback, WithoutItTheKidnappedScansKeepWhatTheyDid) {
  // The control: the chance pairings moved the map and the dropped landmark stays dropped.
  Scene s(rollbackConfig(false));
  const Kidnapped k = kidnap(s);
  EXPECT_EQ(k.lost.rolled_back_scans, 0);
  EXPECT_EQ(k.at_lost.size(), k.before.size() - 1);
  const LandmarkId chance = s.associator().id(0);
  EXPECT_GT((k.at_lost.at(chance) - k.before.at(chance)).norm(), 0.05);
}

TEST(LostRollback, ARunThatNeverGoesLostIsTheRunWithoutIt) {
  // A poor detector at the right pose (1 of 8 paired: every scan suspect, a checkpoint held and
  // renewed) changes nothing: the same state to the last bit.
  Eigen::VectorXd mean[2];
  Eigen::MatrixXd cov[2];
  for (const bool rollback : {false, true}) {
    PipelineConfig config = rollbackConfig(rollback);
    config.lost_share_window = 0;
    Scene s(config);
    EXPECT_FALSE(s.run(30, -1));
    EXPECT_FALSE(s.run(40, 1));
    EXPECT_EQ(s.pipeline().counters().lost_events, 0u);
    mean[rollback] = s.pipeline().ekf().mean();
    cov[rollback] = s.pipeline().ekf().covariance();
  }
  ASSERT_EQ(mean[0].size(), mean[1].size());
  EXPECT_TRUE(mean[0] == mean[1]);
  EXPECT_TRUE(cov[0] == cov[1]);
}

}  // namespace test_lost_rollback
}  // namespace ekf_slam
