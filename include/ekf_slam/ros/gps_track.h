// The GPS reference in rviz (victoria_park.launch): fixes (geometry_msgs/PointStamped in a local
// metric frame) moved into the map frame by a rigid alignment and drawn as line segments that
// stop at dropouts and jumps (core/common/track_split.h), so that no line crosses the map where
// the receiver dropped out or jumped. docs/node.md, "The GPS reference".
#pragma once

#include <string>
#include <vector>

#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>
#include <Eigen/Core>

#include "ekf_slam/core/common/track_split.h"

namespace ekf_slam {

/// The rigid alignment that maps map points into the GPS frame, gps = R(yaw) map + (x, y): the
/// "gps_alignment" of the metrics.json that ekf_slam_offline writes. All zero: the fixes as they
/// are.
struct GpsAlignment {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
  /// map = R(yaw)^T (gps - t).
  Eigen::Vector2d toMap(const Eigen::Vector2d& gps) const;
};

struct GpsTrackStyle {
  double line_width = 0.6;  ///< [m]
};

/// Marker namespaces: every pair of consecutive fixes of a run (one LINE_LIST), and the fixes of
/// runs of one fix, which no line shows (one POINTS). A marker with nothing to draw is sent as
/// DELETE (rviz warns about empty point lists).
constexpr const char* kGpsLinesNs = "gps_lines";
constexpr const char* kGpsLoneFixesNs = "gps_lone_fixes";

/// The two markers for `fixes` (already in frame_id) split into `runs` (splitTrack).
visualization_msgs::MarkerArray gpsTrackMarkers(const std::vector<TrackFix>& fixes,
                                                const std::vector<TrackRun>& runs,
                                                const std::string& frame_id,
                                                const GpsTrackStyle& style = {});

/// `rosrun ekf_slam gps_track`: gps (in), ~markers (out, latched, MarkerArray); parameters in
/// docs/parameters.md, "The GPS reference". An invalid parameter: ROS_FATAL, returns 1.
int runGpsTrackNode();

}  // namespace ekf_slam
