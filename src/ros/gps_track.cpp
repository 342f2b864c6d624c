// The GPS reference in rviz: fixes aligned into the map frame, drawn broken at dropouts and jumps
// (gps_track.h).
#include "ekf_slam/ros/gps_track.h"

#include <cmath>
#include <exception>

#include <geometry_msgs/PointStamped.h>
#include <ros/ros.h>

namespace ekf_slam {

Eigen::Vector2d GpsAlignment::toMap(const Eigen::Vector2d& gps) const {
  const double c = std::cos(yaw), s = std::sin(yaw);
  const Eigen::Vector2d d = gps - Eigen::Vector2d(x, y);
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

visualization_msgs::MarkerArray gpsTrackMarkers(const std::vector<TrackFix>& fixes,
                                                const std::vector<TrackRun>& runs,
                                                const std::string& frame_id,
                                                const GpsTrackStyle& style) {
  using visualization_msgs::Marker;
  auto point = [&](std::size_t i) {
    geometry_msgs::Point p;
    p.x = fixes[i].position.x();
    p.y = fixes[i].position.y();
    return p;
  };
  auto marker = [&](const char* ns, int type) {
    Marker m;
    m.header.frame_id = frame_id;
    // Stamp 0: the track spans the whole run; rviz places it with the latest transform.
    m.header.stamp = ros::Time();
    m.ns = ns;
    m.id = 0;
    m.type = type;
    m.pose.orientation.w = 1.0;  // rviz warns about an unnormalised (all-zero) quaternion
    m.color.r = 0.86f;
    m.color.g = 0.16f;
    m.color.b = 0.16f;
    m.color.a = 1.0f;
    return m;
  };
  Marker lines = marker(kGpsLinesNs, Marker::LINE_LIST);
  lines.scale.x = style.line_width;
  Marker lone = marker(kGpsLoneFixesNs, Marker::POINTS);
  lone.scale.x = lone.scale.y = style.line_width;
  for (const TrackRun& r : runs) {
    if (r.size() == 1) lone.points.push_back(point(r.begin));
    for (std::size_t i = r.begin; i + 1 < r.end; ++i) {
      lines.points.push_back(point(i));
      lines.points.push_back(point(i + 1));
    }
  }
  lines.action = lines.points.empty() ? Marker::DELETE : Marker::ADD;
  lone.action = lone.points.empty() ? Marker::DELETE : Marker::ADD;
  visualization_msgs::MarkerArray array;
  array.markers = {lines, lone};
  return array;
}

int runGpsTrackNode() {
  ros::NodeHandle nh, pnh("~");
  GpsAlignment alignment;
  pnh.param("alignment_x", alignment.x, 0.0);
  pnh.param("alignment_y", alignment.y, 0.0);
  pnh.param("alignment_yaw", alignment.yaw, 0.0);
  std::string frame_id;
  pnh.param<std::string>("frame_id", frame_id, "map");
  TrackSplitOptions split;
  pnh.param("max_gap", split.max_gap, split.max_gap);
  pnh.param("max_speed", split.max_speed, split.max_speed);
  pnh.param("position_tolerance", split.position_tolerance, split.position_tolerance);
  GpsTrackStyle style;
  pnh.param("line_width", style.line_width, style.line_width);
  double publish_rate = 2.0;
  pnh.param("publish_rate", publish_rate, publish_rate);
  try {
    validate(split);
    if (!(std::isfinite(alignment.x) && std::isfinite(alignment.y) && std::isfinite(alignment.yaw)))
      throw std::invalid_argument("alignment_x, alignment_y, alignment_yaw must be finite");
    if (!(std::isfinite(style.line_width) && style.line_width > 0.0))
      throw std::invalid_argument("line_width must be finite and > 0");
    if (!(std::isfinite(publish_rate) && publish_rate > 0.0))
      throw std::invalid_argument("publish_rate must be finite and > 0");
  } catch (const std::exception& e) {
    ROS_FATAL("gps_track: %s", e.what());
    return 1;
  }

  std::vector<TrackFix> fixes;  // in frame_id
  bool dirty = true;            // publish the empty track once, so that rviz has the topic
  ros::Publisher pub = pnh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  const boost::function<void(const geometry_msgs::PointStamped::ConstPtr&)> on_fix =
      [&](const geometry_msgs::PointStamped::ConstPtr& msg) {
        const Eigen::Vector2d gps(msg->point.x, msg->point.y);
        if (!gps.allFinite()) {
          ROS_WARN_THROTTLE(10.0, "gps_track: non-finite fix skipped");
          return;
        }
        const double stamp = msg->header.stamp.toSec();
        if (!fixes.empty() && stamp < fixes.back().stamp) {
          // A restarted bag (the ekf_slam node resets its map too): the old track would overlap.
          ROS_WARN("gps_track: time jumped backwards: track cleared");
          fixes.clear();
        }
        fixes.push_back({stamp, alignment.toMap(gps)});
        dirty = true;
      };
  ros::Subscriber sub = nh.subscribe<geometry_msgs::PointStamped>("gps", 100, on_fix);
  // Wall-clock rate, not per fix: the whole track is re-sent each time (thousands of points), and
  // a bag played fast brings fixes at many times their rate.
  ros::WallTimer timer =
      nh.createWallTimer(ros::WallDuration(1.0 / publish_rate), [&](const ros::WallTimerEvent&) {
        if (!dirty) return;
        dirty = false;
        pub.publish(gpsTrackMarkers(fixes, splitTrack(fixes, split), frame_id, style));
      });
  ros::spin();
  return 0;
}

}  // namespace ekf_slam
