// KidnapOnset: where a kidnap began, from the scans under both hypotheses (the filter's pose, the
// fix carried back by the odometry), and TrackedHistory, which keeps what that needs.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/pipeline/kidnap_onset.h"

namespace ekf_slam {
namespace test_kidnap_onset {

const RangeBearingModel kModel;
constexpr int kScans = 60;
constexpr int kKidnap = 30;

// A vehicle drives 1 m a scan along y = 0 between two rows of trees 6 m apart. From scan kKidnap
// on the filter's estimate is off by `jump` (a kidnap into what it takes for new ground): it maps
// the trees it sees there as new landmarks at the wrong place (the island). The fix is right and
// the odometry exact, so the fix carried back is the truth, unless `physical`: the vehicle itself
// was carried at the kidnap, which the odometry did not see, so the carried-back poses before it
// are off by the jump instead.
struct Scenario {
  std::vector<OnsetLandmark> landmarks;
  std::vector<std::vector<Observation>> observations;
  std::vector<OnsetScan> scans;

  Scenario(const Eigen::Vector3d& jump, bool physical) {
    std::vector<Eigen::Vector2d> trees;
    for (int x = -10; x <= kScans + 20; x += 4) {
      trees.emplace_back(x, 6.0);
      trees.emplace_back(x + 2, -6.0);
    }
    const double sigma = 0.05;
    std::vector<bool> mapped(trees.size(), false);
    observations.resize(kScans);
    for (int k = 0; k < kScans; ++k) {
      const Eigen::Vector3d truth(k, 0.0, 0.0);
      const bool after = k >= kKidnap;
      const Eigen::Vector3d estimate = after ? composePose(jump, truth) : truth;
      for (std::size_t t = 0; t < trees.size(); ++t) {
        if ((trees[t] - truth.head<2>()).norm() > 12.0) continue;
        Observation o;
        o.z = kModel.predict(truth, trees[t]);
        o.R = Eigen::Vector2d(sigma * sigma, 1e-4).asDiagonal();
        observations[k].push_back(o);
        // The filter maps each tree where it first sees it: after the kidnap, in the island.
        if (!after && !mapped[t]) {
          mapped[t] = true;
          landmarks.push_back({trees[t], 0.01 * Eigen::Matrix2d::Identity(), k});
        } else if (after && k == kKidnap) {
          landmarks.push_back(
              {kModel.inverse(estimate, o.z), 0.01 * Eigen::Matrix2d::Identity(), k});
        }
      }
      OnsetScan s;
      s.scan = static_cast<std::uint32_t>(k);
      s.estimate = estimate;
      s.estimate_covariance = Eigen::Vector3d(0.01, 0.01, 1e-4).asDiagonal();
      s.carried = physical && !after ? composePose(inversePose(jump), truth) : truth;
      s.carried_covariance = Eigen::Vector3d(0.01, 0.01, 1e-4).asDiagonal();
      scans.push_back(s);
    }
    for (int k = 0; k < kScans; ++k) scans[k].observations = &observations[k];
  }
};

TEST(KidnapOnset, TheScanTheEstimateJumpedAt) {
  const Scenario s({8.0, -5.0, 1.5}, false);
  const KidnapOnset onset = estimateKidnapOnset(s.scans, s.landmarks, kModel, OnsetParams{});
  ASSERT_TRUE(onset.found);
  EXPECT_EQ(onset.scan, static_cast<std::uint32_t>(kKidnap));
  EXPECT_GT(onset.score, 10.0);
}

TEST(KidnapOnset, TheScanTheVehicleWasCarriedAt) {
  // Before the kidnap the carried-back poses are the wrong ones: the filter explains those scans.
  const Scenario s({8.0, -5.0, 1.5}, true);
  const KidnapOnset onset = estimateKidnapOnset(s.scans, s.landmarks, kModel, OnsetParams{});
  ASSERT_TRUE(onset.found);
  EXPECT_EQ(onset.scan, static_cast<std::uint32_t>(kKidnap));
}

TEST(KidnapOnset, NoneWhereTheFixAgreesWithTheFilter) {
  const Scenario s(Eigen::Vector3d::Zero(), false);
  const KidnapOnset onset = estimateKidnapOnset(s.scans, s.landmarks, kModel, OnsetParams{});
  EXPECT_FALSE(onset.found);
}

TEST(KidnapOnset, NoneBelowTheLeastScore) {
  const Scenario s({8.0, -5.0, 1.5}, false);
  OnsetParams p;
  p.min_score = 1e9;
  EXPECT_FALSE(estimateKidnapOnset(s.scans, s.landmarks, kModel, p).found);
  EXPECT_FALSE(estimateKidnapOnset({}, s.landmarks, kModel, OnsetParams{}).found);
}

TrackedHistory::Record record(std::uint32_t scan) {
  return {scan,
          0.1 * scan,
          Eigen::Vector3d(scan, 0, 0),
          Eigen::Vector3d(scan, 0, 0),
          Eigen::Matrix3d::Identity(),
          true};
}

MapCheckpoint state(std::uint32_t scan) {
  MapCheckpoint c;
  c.held = true;
  c.scan = scan;
  c.mean = Eigen::VectorXd::Constant(3, scan);
  return c;
}

TEST(TrackedHistory, KeepsTheWindowAndAStateEverySpacingScans) {
  TrackedHistory h;
  EXPECT_FALSE(h.active());
  h.configure(100, 10);  // a state every 10 scans
  ASSERT_TRUE(h.active());
  std::vector<Observation> one(1);
  for (std::uint32_t k = 0; k < 150; ++k) {
    if (h.wantsSnapshot(k)) h.addSnapshot(state(k));
    h.add(record(k), k % 2 ? one : std::vector<Observation>{});
  }
  // The last 100 scans; those with observations with their odometry.
  ASSERT_EQ(h.records().size(), 100u);
  EXPECT_EQ(h.records().front().scan, 50u);
  EXPECT_EQ(h.scans().scans().size(), 50u);
  EXPECT_GE(h.scans().scans().front().scan, 50u);
  // States at 50, 60, ..., 140.
  ASSERT_NE(h.snapshotAtOrBefore(75), nullptr);
  EXPECT_EQ(h.snapshotAtOrBefore(75)->scan, 70u);
  EXPECT_EQ(h.snapshotAtOrBefore(49), nullptr);
  // A rollback to before 100 undoes the states from it on.
  h.forgetFrom(100);
  EXPECT_EQ(h.snapshotAtOrBefore(149)->scan, 90u);
  for (const TrackedHistory::Record& r : h.records()) EXPECT_EQ(r.tracked, r.scan < 100) << r.scan;
  EXPECT_TRUE(h.wantsSnapshot(100));
  h.clear();
  EXPECT_TRUE(h.records().empty());
  EXPECT_EQ(h.snapshotAtOrBefore(149), nullptr);
}

}  // namespace test_kidnap_onset
}  // namespace ekf_slam
