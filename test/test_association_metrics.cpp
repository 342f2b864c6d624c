// Association scorer (TP/FP/FN/TN, majority identity, final map) and pose metrics (RMSE, NEES).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/evaluation/scoring/association_metrics.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace test_association_metrics {

constexpr Decision P = Decision::kPaired, N = Decision::kNew, T = Decision::kTentative,
                   X = Decision::kRejected;
constexpr LandmarkId kNone = kNoLandmark;
const LandmarkId kMover = sim::moverId(0), kClutter = sim::kClutterIdBase;

AssociationCounts counts(std::uint64_t tp, std::uint64_t fp, std::uint64_t fn, std::uint64_t tn) {
  AssociationCounts c;
  c.tp = tp;
  c.fp = fp;
  c.fn = fn;
  c.tn = tn;
  return c;
}

void expectCounts(const AssociationCounts& c, std::uint64_t tp, std::uint64_t fp, std::uint64_t fn,
                  std::uint64_t tn) {
  EXPECT_EQ(c.tp, tp);
  EXPECT_EQ(c.fp, fp);
  EXPECT_EQ(c.fn, fn);
  EXPECT_EQ(c.tn, tn);
}

TEST(AssociationCounts, RatiosAndZeroCases) {
  const AssociationCounts c = counts(6, 2, 2, 10);
  EXPECT_DOUBLE_EQ(c.accuracy(), 16.0 / 20.0);
  EXPECT_DOUBLE_EQ(c.precision(), 6.0 / 8.0);
  EXPECT_DOUBLE_EQ(c.recall(), 6.0 / 8.0);
  EXPECT_DOUBLE_EQ(c.f1(), 0.75);
  const AssociationCounts none;
  EXPECT_DOUBLE_EQ(none.accuracy(), 1.0);
  EXPECT_DOUBLE_EQ(none.precision(), 1.0);
  EXPECT_DOUBLE_EQ(none.recall(), 1.0);
  EXPECT_DOUBLE_EQ(none.f1(), 1.0);
  // Nothing paired but landmarks were missed: precision 1 (no wrong claim), recall 0, F1 0.
  const AssociationCounts missed = counts(0, 0, 3, 1);
  EXPECT_DOUBLE_EQ(missed.precision(), 1.0);
  EXPECT_DOUBLE_EQ(missed.recall(), 0.0);
  EXPECT_DOUBLE_EQ(missed.f1(), 0.0);
  // Only wrong pairings: P = 0, R = 1 (nothing missed), F1 = 0.
  EXPECT_DOUBLE_EQ(counts(0, 4, 0, 0).f1(), 0.0);
  AssociationCounts sum = c;
  sum += missed;
  expectCounts(sum, 6, 2, 5, 11);
}

TEST(AssociationScorer, EveryCategoryOnAHandMadeSequence) {
  AssociationScorer s;
  std::vector<Outcome> o;
  // Scan 1: landmarks 0 and 1 seen for the first time and created as map ids 100, 101; a mover
  // is made tentative; clutter rejected. Nothing is in the map yet: all TN.
  expectCounts(s.addScan({0, 1, kMover, kClutter}, {N, N, T, X}, {100, 101, kNone, kNone}, {}, &o),
               0, 0, 0, 4);
  LandmarkId id = -99;
  ASSERT_TRUE(s.identity(100, &id));
  EXPECT_EQ(id, 0);
  // Scan 2: 0 -> 100 (TP); 1 -> 100 (wrong landmark: FP); landmark 0 again made new (duplicate
  // of a mapped landmark: FN); mover paired with 101 (FP); landmark 2, not in the map, left
  // tentative (TN); landmark 1 rejected although 101 is landmark 1 (FN); clutter paired (FP).
  const AssociationCounts c2 =
      s.addScan({0, 1, 0, kMover, 2, 1, kClutter}, {P, P, N, P, T, X, P},
                {100, 100, 102, 101, 101 /* ignored: not paired */, kNone, 100}, {}, &o);
  expectCounts(c2, 1, 3, 2, 1);
  EXPECT_EQ(o, (std::vector<Outcome>{Outcome::kTruePositive, Outcome::kFalsePositive,
                                     Outcome::kFalseNegative, Outcome::kFalsePositive,
                                     Outcome::kTrueNegative, Outcome::kFalseNegative,
                                     Outcome::kFalsePositive}));
  expectCounts(s.counts(), 1, 3, 2, 5);
  EXPECT_EQ(s.scans(), 2u);
  // Votes now: 100 {0: 2, 1: 1, clutter: 1}, 101 {1: 1, mover: 1} (tie keeps 1), 102 {0: 1}.
  ASSERT_TRUE(s.identity(101, &id));
  EXPECT_EQ(id, 1);
  const MapScore m = s.mapScore();
  EXPECT_EQ(m.landmarks, 3u);
  EXPECT_EQ(m.true_landmarks_mapped, 2u);
  EXPECT_EQ(m.true_landmarks_seen, 3u);  // 0, 1, 2
  EXPECT_EQ(m.duplicates, 1u);           // 100 and 102 are both landmark 0
  EXPECT_EQ(m.non_landmarks, 0u);
  EXPECT_EQ(m.spurious, 1u);
}

TEST(AssociationScorer, MajorityIdentitySwitchesAndDecidesLaterOutcomes) {
  AssociationScorer s;
  s.addScan({5}, {N}, {7}, {});  // map 7 created by landmark 5
  // Landmark 6's returns keep being paired with 7: FP while 7 is "landmark 5"...
  expectCounts(s.addScan({6}, {P}, {7}, {}), 0, 1, 0, 0);  // votes 5:1, 6:1 (tie keeps 5)
  LandmarkId id;
  ASSERT_TRUE(s.identity(7, &id));
  EXPECT_EQ(id, 5);
  expectCounts(s.addScan({6}, {P}, {7}, {}), 0, 1, 0, 0);  // judged before the vote: FP
  ASSERT_TRUE(s.identity(7, &id));
  EXPECT_EQ(id, 6);  // votes 5:1, 6:2: identity switched
  EXPECT_EQ(s.identitySwitches(), 1u);
  // ...and TP from then on, while landmark 5's returns paired with 7 become FP, and an
  // unpaired return of 5 is now TN (no map landmark is 5 any more).
  expectCounts(s.addScan({6, 5}, {P, P}, {7, 7}, {}), 1, 1, 0, 0);
  expectCounts(s.addScan({5, 6}, {T, X}, {kNone, kNone}, {}), 0, 0, 1, 1);
  // Mover-made landmark: its identity is the mover, it is spurious.
  s.addScan({kMover}, {N}, {8}, {});
  EXPECT_EQ(s.mapScore().non_landmarks, 1u);
  expectCounts(s.addScan({kMover}, {P}, {8}, {}), 0, 1, 0, 0);  // movers paired are always FP
}

// After a kidnapping a filter may build a second map of the same place: pairing with the
// duplicate is not the right association, only the oldest representative is.
TEST(AssociationScorer, PairingWithAYoungerDuplicateIsFalse) {
  AssociationScorer s;
  s.addScan({3}, {N}, {10}, {});
  s.addScan({3}, {N}, {20}, {});                            // duplicate of landmark 3 (FN)
  expectCounts(s.addScan({3}, {P}, {20}, {}), 0, 1, 0, 0);  // the duplicate: FP
  EXPECT_EQ(s.duplicatePairings(), 1u);
  expectCounts(s.addScan({3}, {P}, {10}, {}), 1, 0, 0, 0);  // the original: TP
  // Once the original is removed the duplicate is the landmark's representative.
  s.addScan({3}, {T}, {kNone}, {10});
  expectCounts(s.addScan({3}, {P}, {20}, {}), 1, 0, 0, 0);
  EXPECT_EQ(s.mapScore().duplicates, 0u);
}

TEST(AssociationScorer, RemovalsAndUnknownLandmarks) {
  AssociationScorer s;
  s.addScan({3}, {N}, {10}, {});
  expectCounts(s.addScan({3}, {T}, {kNone}, {10}), 0, 0, 1, 0);  // FN, then 10 is removed
  EXPECT_FALSE(s.identity(10, nullptr));
  expectCounts(s.addScan({3}, {T}, {kNone}, {}), 0, 0, 0, 1);  // no longer mapped: TN
  EXPECT_EQ(s.mapScore().landmarks, 0u);
  // A landmark the scorer never saw created: FP (unverifiable), tracked from then on.
  expectCounts(s.addScan({4}, {P}, {55}, {}), 0, 1, 0, 0);
  EXPECT_EQ(s.unknownPairings(), 1u);
  expectCounts(s.addScan({4}, {P}, {55}, {}), 1, 0, 0, 0);
  // Loaded maps declare their identities.
  s.addKnownLandmark(60, 9);
  expectCounts(s.addScan({9}, {P}, {60}, {}), 1, 0, 0, 0);
  // A kNew the pipeline could not initialise creates nothing.
  s.addScan({11}, {N}, {kNone}, {});
  EXPECT_EQ(s.mapScore().landmarks, 2u);
  EXPECT_THROW(s.addScan({1, 2}, {P}, {1}, {}), std::invalid_argument);
  s.reset();
  EXPECT_EQ(s.counts().total(), 0u);
  EXPECT_EQ(s.mapScore().landmarks, 0u);
}

// --- pose metrics --------------------------------------------------------------------------------

// Withholding decisions must not pay: the same accuracy, but the coverage shows what was lost.
TEST(AssociationScorer, WithholdingKeepsAccuracyButLosesCoverage) {
  AssociationScorer eager, shy;
  // Landmark 0 seen five times. Eager: created at once, then paired. Shy: tentative three times.
  eager.addScan({0}, {N}, {10}, {});
  for (int i = 0; i < 4; ++i) eager.addScan({0}, {P}, {10}, {});
  for (int i = 0; i < 3; ++i) shy.addScan({0}, {T}, {kNone}, {});
  shy.addScan({0}, {N}, {10}, {});
  shy.addScan({0}, {P}, {10}, {});
  EXPECT_DOUBLE_EQ(eager.counts().accuracy(), 1.0);
  EXPECT_DOUBLE_EQ(shy.counts().accuracy(), 1.0);  // tentative before mapping = TN
  EXPECT_DOUBLE_EQ(eager.mapScore().pairing_coverage, 4.0 / 5.0);
  EXPECT_DOUBLE_EQ(shy.mapScore().pairing_coverage, 1.0 / 5.0);
  EXPECT_EQ(eager.mapScore().landmarks_created, 1u);
}

TEST(AssociationScorer, LandmarkPrecisionRecallAndCreated) {
  AssociationScorer s;
  // 0: seen 3 times, mapped once (found). 1: seen 3 times, mapped twice (duplicate: not found).
  // 2: seen twice, never mapped (not findable). A clutter return becomes landmark 30.
  s.addScan({0, 1, 2, kClutter}, {N, N, T, N}, {10, 20, kNone, 30}, {});
  s.addScan({0, 1, 2}, {P, N, T}, {10, 21, kNone}, {});
  s.addScan({0, 1}, {P, P}, {10, 20}, {});
  // 3: seen 3 times, created, then removed (not found; created counts stay).
  s.addScan({3}, {N}, {40}, {});
  s.addScan({3}, {P}, {40}, {});
  s.addScan({3}, {P}, {40}, {40});
  const MapScore m = s.mapScore();
  EXPECT_EQ(m.landmarks, 4u);  // 10, 20, 21, 30
  EXPECT_EQ(m.landmarks_created, 5u);
  EXPECT_EQ(m.true_landmarks_findable, 3u);  // 0, 1, 3
  EXPECT_EQ(m.true_landmarks_found, 1u);     // 0
  EXPECT_DOUBLE_EQ(m.landmark_recall, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.landmark_precision, 1.0 / 4.0);  // only 10 holds its landmark alone
  // Observations of mapped landmarks 0 and 1: 6, of which TP: 0 twice, 1 once (20, the oldest).
  EXPECT_DOUBLE_EQ(m.pairing_coverage, 3.0 / 6.0);
}

TEST(PoseMetrics, NeesBandMatchesThePaper) {
  const NeesBand b = neesBand(50, 3, 0.95);
  EXPECT_NEAR(b.lower, 2.36, 0.005);
  EXPECT_NEAR(b.upper, 3.72, 0.005);
  EXPECT_TRUE(b.contains(3.0));
  EXPECT_FALSE(b.contains(4.0));
  const NeesBand one = neesBand(1, 3, 0.95);  // chi2(3) quantiles 0.216 and 9.348
  EXPECT_NEAR(one.lower, 0.2158, 1e-3);
  EXPECT_NEAR(one.upper, 9.3484, 1e-3);
  EXPECT_THROW(neesBand(0), std::invalid_argument);
}

TEST(PoseMetrics, NeesRmseOfKnownErrors) {
  const Eigen::Matrix3d cov = Eigen::Vector3d(4.0, 1.0, 0.01).asDiagonal();
  EXPECT_NEAR(poseNees({2, 1, 0.1}, cov, {0, 0, 0}), 1.0 + 1.0 + 1.0, 1e-12);
  // Heading errors wrap.
  EXPECT_NEAR(poseNees({0, 0, M_PI - 0.05}, cov, {0, 0, -M_PI + 0.05}), 0.01 / 0.01, 1e-9);
  EXPECT_TRUE(std::isnan(poseNees({0, 0, 0}, Eigen::Matrix3d::Zero(), {1, 0, 0})));
  PoseErrorStats s;
  s.add({3, 4, 0.2}, cov, {0, 0, 0});
  s.add({0, 0, 0}, cov, {0, 0, 0});
  s.add({0, 0, 0}, Eigen::Matrix3d::Zero(), {0, 0, 0});
  EXPECT_NEAR(s.positionRmse(), std::sqrt(25.0 / 3.0), 1e-12);
  EXPECT_NEAR(s.headingRmse(), std::sqrt(0.04 / 3.0), 1e-12);
  EXPECT_EQ(s.invalidNees(), 1u);
  EXPECT_NEAR(s.meanNees(), (9.0 / 4 + 16.0 + 4.0) / 2.0, 1e-9);
}

/// ANEES over 50 runs of a filter whose estimates are truth + noise drawn from `true_cov` while it
/// reports `stated_cov`, along the tiny world's true trajectory.
MonteCarloNees monteCarlo(double true_scale) {
  const sim::World w = sim::makeWorld("tiny");
  MonteCarloNees mc;
  for (int run = 0; run < 50; ++run) {
    sim::Simulation s(w, 100 + run);
    sim::Random noise(sim::Random::streamSeed(100 + run, 99));
    std::size_t scan = 0;
    for (auto e = s.next(); e != sim::Simulation::Event::kEnd; e = s.next()) {
      if (e != sim::Simulation::Event::kObservations) continue;
      const Eigen::Vector3d& truth = s.observations().true_pose;
      // A covariance that changes along the run, with correlations.
      const double g = 1.0 + 0.5 * std::sin(0.05 * scan);
      Eigen::Matrix3d cov;
      cov << 0.04 * g, 0.01, 0.001, 0.01, 0.09, -0.002, 0.001, -0.002, 0.0025 * g;
      const Eigen::Matrix3d L = Eigen::LLT<Eigen::Matrix3d>(cov).matrixL();
      const Eigen::Vector3d n(noise.normal(), noise.normal(), noise.normal());
      Eigen::Vector3d est = truth + std::sqrt(true_scale) * (L * n);
      est(2) = wrapAngle(est(2));
      mc.add(scan++, poseNees(est, cov, truth));
    }
  }
  return mc;
}

TEST(PoseMetrics, PerfectFilterSitsInTheBandAndAnOverconfidentOneDoesNot) {
  const MonteCarloNees perfect = monteCarlo(1.0);
  ASSERT_GT(perfect.scans(), 100u);
  EXPECT_EQ(perfect.runs(0), 50);
  // 95 % band per scan: about 95 % of scans inside (binomial, 5 sigma margin).
  const double n = static_cast<double>(perfect.scans());
  EXPECT_GT(perfect.fractionInBand(), 0.95 - 5.0 * std::sqrt(0.95 * 0.05 / n));
  double mean = 0.0;
  for (std::size_t k = 0; k < perfect.scans(); ++k) mean += perfect.average(k) / n;
  EXPECT_NEAR(mean, 3.0, 0.1);
  // Errors twice as large (in variance) as the filter claims: out of the band.
  EXPECT_LT(monteCarlo(2.0).fractionInBand(), 0.05);
}

}  // namespace test_association_metrics
}  // namespace ekf_slam
