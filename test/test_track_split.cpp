// splitTrack (core/common/track_split.h): a GPS track is broken at dropouts and at jumps the
// vehicle cannot have driven, and nowhere else.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/core/common/track_split.h"

namespace ekf_slam {
namespace test_track_split {

// 5 Hz fixes along x at 4 m/s (0.8 m per fix), from x0 at t0.
void drive(std::vector<TrackFix>* fixes, double t0, double x0, int n) {
  for (int k = 0; k < n; ++k) fixes->push_back({t0 + 0.2 * k, {x0 + 0.8 * k, 0.0}});
}

std::vector<std::size_t> sizes(const std::vector<TrackRun>& runs) {
  std::vector<std::size_t> out;
  for (const TrackRun& r : runs) out.push_back(r.size());
  return out;
}

TrackSplitOptions options() {
  TrackSplitOptions o;
  o.max_gap = 1.0;
  o.max_speed = 10.0;
  o.position_tolerance = 3.0;
  return o;
}

TEST(TrackSplit, AContinuousDriveIsOneRun) {
  std::vector<TrackFix> fixes;
  drive(&fixes, 10.0, 0.0, 50);
  const std::vector<TrackRun> runs = splitTrack(fixes, options());
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].begin, 0u);
  EXPECT_EQ(runs[0].end, 50u);
}

TEST(TrackSplit, EmptyAndSingleFix) {
  EXPECT_TRUE(splitTrack({}, options()).empty());
  EXPECT_EQ(sizes(splitTrack({{1.0, {2.0, 3.0}}}, options())), std::vector<std::size_t>{1});
}

// A dropout: no fix for 30 s, then the track resumes 120 m further on (the vehicle drove there
// meanwhile). Plausible for the vehicle, but nothing was measured in between: two runs.
TEST(TrackSplit, ADropoutStartsANewRun) {
  std::vector<TrackFix> fixes;
  drive(&fixes, 0.0, 0.0, 10);
  drive(&fixes, 31.8, 127.2, 10);
  EXPECT_EQ(sizes(splitTrack(fixes, options())), (std::vector<std::size_t>{10, 10}));
}

// The gap rule is max_gap itself: 0.9 s without a fix (4 missed at 5 Hz) still joins, 1.1 s not.
TEST(TrackSplit, GapThresholdIsMaxGap) {
  std::vector<TrackFix> joined = {{0.0, {0.0, 0.0}}, {0.9, {3.0, 0.0}}};
  EXPECT_EQ(splitTrack(joined, options()).size(), 1u);
  std::vector<TrackFix> split = {{0.0, {0.0, 0.0}}, {1.1, {3.0, 0.0}}};
  EXPECT_EQ(splitTrack(split, options()).size(), 2u);
}

// A jump out and back (the receiver failing): one fix 80 m off the path at 5 Hz. It is drawn
// alone, and no line joins it to the path on either side.
TEST(TrackSplit, AJumpOutAndBackIsolatesTheFix) {
  std::vector<TrackFix> fixes;
  drive(&fixes, 0.0, 0.0, 10);
  fixes.push_back({2.0, {8.0, 80.0}});
  drive(&fixes, 2.2, 8.8, 10);
  const std::vector<TrackRun> runs = splitTrack(fixes, options());
  EXPECT_EQ(sizes(runs), (std::vector<std::size_t>{10, 1, 10}));
  EXPECT_EQ(runs[1].begin, 10u);
}

// The jump rule is max_speed * dt + position_tolerance: at dt = 0.2 s, 10 m/s and 3 m, a step of
// 4.9 m joins and 5.1 m splits; a faster vehicle (max_speed 20 m/s: 7 m) joins both.
TEST(TrackSplit, JumpThresholdIsSpeedTimesTimePlusTolerance) {
  std::vector<TrackFix> near = {{0.0, {0.0, 0.0}}, {0.2, {0.0, 4.9}}};
  std::vector<TrackFix> far = {{0.0, {0.0, 0.0}}, {0.2, {0.0, 5.1}}};
  EXPECT_EQ(splitTrack(near, options()).size(), 1u);
  EXPECT_EQ(splitTrack(far, options()).size(), 2u);
  TrackSplitOptions fast = options();
  fast.max_speed = 20.0;
  EXPECT_EQ(splitTrack(far, fast).size(), 1u);
  TrackSplitOptions exact = options();
  exact.position_tolerance = 0.0;
  EXPECT_EQ(splitTrack(near, exact).size(), 2u);
}

// A lasting shift (the receiver changed its solution): the track after it is one run again.
TEST(TrackSplit, ALastingShiftSplitsOnce) {
  std::vector<TrackFix> fixes;
  drive(&fixes, 0.0, 0.0, 10);
  drive(&fixes, 2.0, 8.0 + 40.0, 10);
  EXPECT_EQ(sizes(splitTrack(fixes, options())), (std::vector<std::size_t>{10, 10}));
}

// Time going backwards (a bag restarted) or standing still never joins two fixes.
TEST(TrackSplit, StampsNotIncreasingSplit) {
  std::vector<TrackFix> fixes = {{5.0, {0.0, 0.0}},
                                 {5.2, {0.5, 0.0}},
                                 {0.0, {0.6, 0.0}},
                                 {0.0, {0.6, 0.0}},
                                 {0.2, {1.0, 0.0}}};
  EXPECT_EQ(sizes(splitTrack(fixes, options())), (std::vector<std::size_t>{2, 1, 2}));
}

// A non-finite fix is in no run and no line crosses it; the runs are in order and cover every
// finite fix exactly once.
TEST(TrackSplit, NonFiniteFixesBelongToNoRun) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<TrackFix> fixes;
  drive(&fixes, 0.0, 0.0, 5);
  fixes.push_back({1.0, {nan, 0.0}});
  drive(&fixes, 1.2, 4.8, 5);
  fixes.push_back({nan, {10.0, 0.0}});
  const std::vector<TrackRun> runs = splitTrack(fixes, options());
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].begin, 0u);
  EXPECT_EQ(runs[0].end, 5u);
  EXPECT_EQ(runs[1].begin, 6u);
  EXPECT_EQ(runs[1].end, 11u);
}

TEST(TrackSplit, InvalidOptionsAreRefused) {
  TrackSplitOptions o = options();
  EXPECT_NO_THROW(validate(o));
  o.max_gap = 0.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = options();
  o.max_speed = -1.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = options();
  o.position_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = options();
  o.position_tolerance = 0.0;
  EXPECT_NO_THROW(validate(o));
}

}  // namespace test_track_split
}  // namespace ekf_slam
