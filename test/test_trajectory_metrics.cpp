#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"

namespace ekf_slam {
namespace test_trajectory_metrics {

// A figure-of-eight-ish path sampled at 5 Hz for 200 s (not symmetric, so the alignment is
// unique).
std::vector<StampedPoint> path(double dt = 0.2, double duration = 200.0) {
  std::vector<StampedPoint> out;
  for (double t = 0.0; t <= duration + 1e-9; t += dt) {
    out.push_back({t, Eigen::Vector2d(40.0 * std::sin(0.03 * t) + 0.2 * t,
                                      25.0 * std::sin(0.06 * t) + 5.0 * std::cos(0.011 * t))});
  }
  return out;
}

RigidTransform2 someTransform() {
  RigidTransform2 t;
  t.yaw = 0.7;
  t.translation = Eigen::Vector2d(120.0, -35.0);
  return t;
}

TEST(AlignRigid2D, RecoversAKnownTransform) {
  std::vector<Eigen::Vector2d> a, b;
  const auto t = someTransform();
  for (const auto& p : path()) {
    a.push_back(p.position);
    b.push_back(t.apply(p.position));
  }
  const auto found = alignRigid2D(a, b);
  EXPECT_NEAR(found.yaw, 0.7, 1e-9);
  EXPECT_NEAR(found.translation.x(), 120.0, 1e-7);
  EXPECT_NEAR(found.translation.y(), -35.0, 1e-7);
}

TEST(AlignRigid2D, HandlesAHalfTurn) {
  std::vector<Eigen::Vector2d> a{{0, 0}, {1, 0}, {0, 2}}, b;
  RigidTransform2 t;
  t.yaw = M_PI;
  for (const auto& p : a) b.push_back(t.apply(p));
  EXPECT_NEAR(std::abs(alignRigid2D(a, b).yaw), M_PI, 1e-12);
}

TEST(AlignRigid2D, DegenerateInputIsATranslation) {
  EXPECT_EQ(alignRigid2D({}, {}).yaw, 0.0);
  const auto t = alignRigid2D({{1, 1}}, {{4, 5}});
  EXPECT_EQ(t.yaw, 0.0);
  EXPECT_TRUE(t.translation.isApprox(Eigen::Vector2d(3, 4)));
}

TEST(InterpolatePosition, LinearBetweenSamplesAndEmptyOutside) {
  const std::vector<StampedPoint> traj{{1.0, {0, 0}}, {2.0, {10, 0}}, {5.0, {10, 30}}};
  EXPECT_TRUE(interpolatePosition(traj, 1.25, 1.0)->isApprox(Eigen::Vector2d(2.5, 0)));
  EXPECT_TRUE(interpolatePosition(traj, 2.0, 1.0)->isApprox(Eigen::Vector2d(10, 0)));
  EXPECT_TRUE(interpolatePosition(traj, 1.0, 1.0)->isApprox(Eigen::Vector2d(0, 0)));
  EXPECT_FALSE(interpolatePosition(traj, 0.5, 1.0));
  EXPECT_FALSE(interpolatePosition(traj, 5.5, 1.0));
  EXPECT_FALSE(interpolatePosition(traj, 3.0, 1.0));  // 3 s hole in the estimate
  EXPECT_TRUE(interpolatePosition(traj, 3.0, 5.0)->isApprox(Eigen::Vector2d(10, 10)));
  EXPECT_FALSE(interpolatePosition({}, 1.0, 1.0));
}

TEST(CompareTrajectories, RigidCopyHasZeroAlignedErrorAndKnownUnalignedError) {
  const auto est = path();
  // Pure translation: every point is off by exactly |t|.
  std::vector<StampedPoint> shifted;
  for (const auto& p : est) shifted.push_back({p.stamp, p.position + Eigen::Vector2d(3, 4)});
  auto e = compareTrajectories(est, shifted);
  EXPECT_EQ(e.points, est.size());
  EXPECT_EQ(e.skipped, 0u);
  EXPECT_NEAR(e.rmse_aligned, 0.0, 1e-9);
  EXPECT_NEAR(e.rmse_unaligned, 5.0, 1e-9);

  // Rotation + translation: unaligned RMSE computed directly.
  const auto t = someTransform();
  std::vector<StampedPoint> moved;
  double sum = 0.0;
  for (const auto& p : est) {
    moved.push_back({p.stamp, t.apply(p.position)});
    sum += (t.apply(p.position) - p.position).squaredNorm();
  }
  e = compareTrajectories(est, moved);
  EXPECT_NEAR(e.rmse_aligned, 0.0, 1e-7);
  EXPECT_NEAR(e.rmse_unaligned, std::sqrt(sum / est.size()), 1e-9);
  EXPECT_NEAR(e.alignment.yaw, 0.7, 1e-9);
  EXPECT_NEAR(e.max_aligned, 0.0, 1e-6);
}

TEST(CompareTrajectories, InterpolatesAtReferenceStamps) {
  // A straight line at 1 m/s sampled at 5 Hz; reference at odd stamps on the same line.
  std::vector<StampedPoint> est, ref;
  for (int i = 0; i <= 100; ++i) est.push_back({0.2 * i, {0.2 * i, 0.0}});
  for (int i = 0; i < 19; ++i) {
    const double s = 0.37 + i;
    ref.push_back({s, {s, 0.0}});
  }
  const auto e = compareTrajectories(est, ref);
  EXPECT_EQ(e.points, ref.size());
  EXPECT_NEAR(e.rmse_unaligned, 0.0, 1e-12);
}

TEST(CompareTrajectories, IsotropicNoiseGivesTheExpectedRmse) {
  // Reference = rigid copy + N(0, sigma^2) per axis: the aligned RMSE estimates sigma * sqrt(2)
  // (minus a negligible 3 dof fitted away).
  const auto est = path(0.2, 2000.0);
  const auto t = someTransform();
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 1.5);
  std::vector<StampedPoint> ref;
  for (const auto& p : est) {
    ref.push_back({p.stamp, t.apply(p.position) + Eigen::Vector2d(noise(rng), noise(rng))});
  }
  const auto e = compareTrajectories(est, ref);
  EXPECT_NEAR(e.rmse_aligned, 1.5 * std::sqrt(2.0), 0.05);
  EXPECT_NEAR(e.alignment.yaw, 0.7, 1e-3);
}

TEST(CompareTrajectories, SkipsGapsOutsidePointsAndNaNs) {
  auto est = path();
  // A 10 s hole in the estimate (e.g. the run lost scans) and a reference with GPS outages.
  est.erase(std::remove_if(est.begin(), est.end(),
                           [](const StampedPoint& p) { return p.stamp > 50 && p.stamp < 60; }),
            est.end());
  std::vector<StampedPoint> ref;
  for (double s = -5.0; s < 210.0; s += 1.0) {
    if (s > 100 && s < 120) continue;  // GPS outage: simply no fixes
    ref.push_back({s + 0.1, {0, 0}});
  }
  ref.push_back({30.0, {std::nan(""), 0}});
  // Fill the usable references with the exact rigid copy.
  const auto t = someTransform();
  for (auto& r : ref) {
    if (auto p = interpolatePosition(path(), r.stamp, 1.0); p && r.position.allFinite()) {
      r.position = t.apply(*p);
    }
  }
  const auto e = compareTrajectories(est, ref);
  // Skipped: 5 before the start, 10 in the hole, 10 after the end, the NaN.
  EXPECT_EQ(e.skipped, 5u + 10u + 10u + 1u);
  EXPECT_EQ(e.points + e.skipped, ref.size());
  EXPECT_NEAR(e.rmse_aligned, 0.0, 1e-6);
}

TEST(CompareTrajectories, MedianIgnoresAWildReferencePoint) {
  // A straight line at 1 m/s sampled at 5 Hz: the reference is 1 m to the side, except one wild
  // fix 100 m away. RMSE feels it, the median and p95 do not.
  std::vector<StampedPoint> est, ref;
  for (int i = 0; i <= 1000; ++i) est.push_back({0.2 * i, {0.2 * i, 0.0}});
  for (int i = 0; i < 100; ++i) ref.push_back({1.0 + i, {1.0 + i, 1.0}});
  auto e = compareTrajectories(est, ref);
  EXPECT_NEAR(e.rmse_unaligned, 1.0, 1e-12);
  EXPECT_NEAR(e.median_aligned, 0.0, 1e-9);
  ref[50].position.y() += 100.0;
  e = compareTrajectories(est, ref);
  EXPECT_GT(e.rmse_aligned, 9.0);
  EXPECT_GT(e.max_aligned, 90.0);
  EXPECT_LT(e.median_aligned, 1.5);
  EXPECT_LT(e.p95_aligned, 3.0);
}

TEST(CompareTrajectories, UnsortedEstimateAndNoOverlap) {
  auto est = path();
  std::reverse(est.begin(), est.end());
  std::vector<StampedPoint> ref{{10.05, {0, 0}}};
  ref[0].position = *interpolatePosition(path(), 10.05, 1.0);
  auto e = compareTrajectories(est, ref);
  EXPECT_EQ(e.points, 1u);
  EXPECT_NEAR(e.rmse_unaligned, 0.0, 1e-9);

  e = compareTrajectories(est, {{1000.0, {0, 0}}});
  EXPECT_EQ(e.points, 0u);
  EXPECT_TRUE(std::isnan(e.rmse_aligned));
  EXPECT_TRUE(std::isnan(e.rmse_unaligned));
}

// --- faulty GPS fixes ---------------------------------------------------------------------------

// A vehicle driving a circle of radius 50 m at 5 m/s (odometry at 40 Hz), GPS at 2 Hz with 0.5 m
// noise.
struct Drive {
  std::vector<StampedPoint> gps;
  std::vector<StampedSpeed> odometry;
};

Drive circleDrive(double duration = 120.0) {
  Drive d;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.5);
  for (double t = 0.0; t <= duration; t += 0.025) d.odometry.push_back({t, 5.0});
  for (double t = 0.3; t < duration; t += 0.5) {
    const double a = 5.0 * t / 50.0;
    d.gps.push_back({t, Eigen::Vector2d(50.0 * std::cos(a) + n(rng), 50.0 * std::sin(a) + n(rng))});
  }
  return d;
}

std::size_t count(const std::vector<bool>& v) {
  return static_cast<std::size_t>(std::count(v.begin(), v.end(), true));
}

TEST(FaultyGpsFixes, CleanTrackHasNone) {
  const Drive d = circleDrive();
  EXPECT_EQ(count(faultyGpsFixes(d.gps, d.odometry)), 0u);
}

TEST(FaultyGpsFixes, SpikesAndShortExcursionsAreFlagged) {
  Drive d = circleDrive();
  d.gps[40].position += Eigen::Vector2d(12.0, -5.0);                                // one wild fix
  for (int i = 100; i < 104; ++i) d.gps[i].position += Eigen::Vector2d(0.0, 25.0);  // 2 s away
  const std::vector<bool> f = faultyGpsFixes(d.gps, d.odometry);
  EXPECT_TRUE(f[40]);
  for (int i = 100; i < 104; ++i) EXPECT_TRUE(f[i]) << i;
  EXPECT_EQ(count(f), 5u);
}

TEST(FaultyGpsFixes, JumpsTheOdometryExplainsAreNot) {
  // The vehicle really moves 12 m between two fixes (a GPS outage of 2.4 s): consistent.
  Drive d = circleDrive();
  d.gps.erase(d.gps.begin() + 50, d.gps.begin() + 54);
  EXPECT_EQ(count(faultyGpsFixes(d.gps, d.odometry)), 0u);
  // A jump that lasts longer than max_run fixes is not judged (nothing says which side is right).
  Drive e = circleDrive();
  for (std::size_t i = 60; i < e.gps.size(); ++i) e.gps[i].position += Eigen::Vector2d(10.0, 0.0);
  EXPECT_EQ(count(faultyGpsFixes(e.gps, e.odometry)), 0u);
  // Without odometry speed, even a small true motion is a jump: the rule needs the odometry.
  std::vector<StampedSpeed> still = {{0.0, 0.0}};
  EXPECT_GT(count(faultyGpsFixes(circleDrive().gps, still, {3.0, 0.2, 1000})), 0u);
}

}  // namespace test_trajectory_metrics
}  // namespace ekf_slam
