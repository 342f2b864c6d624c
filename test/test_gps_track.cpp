// The GPS reference's markers (ros/gps_track.h): lines only within a run of splitTrack, lone fixes
// as points, DELETE instead of empty lists, and the alignment into the map frame.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/ros/gps_track.h"

namespace ekf_slam {
namespace test_gps_track {

using visualization_msgs::Marker;

// 5 Hz fixes at 4 m/s along x, a dropout of 20 s, three fixes, one fix 60 m off the path, back.
std::vector<TrackFix> track() {
  std::vector<TrackFix> f;
  for (int k = 0; k < 4; ++k) f.push_back({0.2 * k, {0.8 * k, 0.0}});
  for (int k = 0; k < 3; ++k) f.push_back({20.0 + 0.2 * k, {80.0 + 0.8 * k, 0.0}});
  f.push_back({20.6, {82.4, 60.0}});
  f.push_back({20.8, {83.2, 0.0}});
  return f;
}

TEST(GpsTrack, LinesJoinOnlyConsecutiveFixesOfARun) {
  const std::vector<TrackFix> f = track();
  const std::vector<TrackRun> runs = splitTrack(f);
  const visualization_msgs::MarkerArray a = gpsTrackMarkers(f, runs, "map");
  ASSERT_EQ(a.markers.size(), 2u);
  const Marker& lines = a.markers[0];
  const Marker& lone = a.markers[1];
  EXPECT_EQ(lines.ns, kGpsLinesNs);
  EXPECT_EQ(lines.type, Marker::LINE_LIST);
  EXPECT_EQ(lines.action, Marker::ADD);
  EXPECT_EQ(lines.header.frame_id, "map");
  EXPECT_DOUBLE_EQ(lines.pose.orientation.w, 1.0);
  // Runs: 4 fixes (3 segments), 3 fixes (2), the lone jump, the lone return after it.
  ASSERT_EQ(lines.points.size(), 2u * (3 + 2));
  // No segment is longer than a step of the drive: none crosses the dropout or the jump.
  for (std::size_t i = 0; i < lines.points.size(); i += 2) {
    const double d = std::hypot(lines.points[i + 1].x - lines.points[i].x,
                                lines.points[i + 1].y - lines.points[i].y);
    EXPECT_NEAR(d, 0.8, 1e-9) << "segment " << i / 2;
  }
  EXPECT_EQ(lone.ns, kGpsLoneFixesNs);
  EXPECT_EQ(lone.type, Marker::POINTS);
  EXPECT_EQ(lone.action, Marker::ADD);
  ASSERT_EQ(lone.points.size(), 2u);
  EXPECT_DOUBLE_EQ(lone.points[0].y, 60.0);
  EXPECT_DOUBLE_EQ(lone.points[1].x, 83.2);
}

TEST(GpsTrack, NothingToDrawIsDeleteNotAnEmptyList) {
  const visualization_msgs::MarkerArray empty = gpsTrackMarkers({}, {}, "map");
  ASSERT_EQ(empty.markers.size(), 2u);
  EXPECT_EQ(empty.markers[0].action, Marker::DELETE);
  EXPECT_EQ(empty.markers[1].action, Marker::DELETE);
  std::vector<TrackFix> f = {{0.0, {0.0, 0.0}}, {0.2, {0.5, 0.0}}};
  const visualization_msgs::MarkerArray joined = gpsTrackMarkers(f, splitTrack(f), "map");
  EXPECT_EQ(joined.markers[0].action, Marker::ADD);
  EXPECT_EQ(joined.markers[1].action, Marker::DELETE);
}

// gps = R(yaw) map + t, so toMap inverts it.
TEST(GpsTrack, AlignmentMapsGpsIntoTheMapFrame) {
  GpsAlignment a;
  a.x = -71.48;
  a.y = -42.81;
  a.yaw = 0.62;
  const Eigen::Vector2d map(12.0, -5.0);
  const Eigen::Vector2d gps =
      Eigen::Vector2d(std::cos(a.yaw) * map.x() - std::sin(a.yaw) * map.y() + a.x,
                      std::sin(a.yaw) * map.x() + std::cos(a.yaw) * map.y() + a.y);
  EXPECT_NEAR((a.toMap(gps) - map).norm(), 0.0, 1e-12);
  EXPECT_NEAR((GpsAlignment().toMap(gps) - gps).norm(), 0.0, 0.0);
}

}  // namespace test_gps_track
}  // namespace ekf_slam
