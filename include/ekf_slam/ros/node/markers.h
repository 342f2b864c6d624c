// rviz markers of the map: per landmark a cylinder (its trunk diameter when known), its 95 %
// covariance ellipse and its id; the associator's tentative features in another colour. Landmarks
// that left the map get DELETE markers, so rviz never shows stale ones.
#pragma once

#include <string>
#include <unordered_set>

#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include "ekf_slam/app/node_config.h"  // MarkerStyle
#include "ekf_slam/core/pipeline/slam_pipeline.h"

namespace ekf_slam {

/// Builds MarkerArrays for successive maps, remembering which landmarks it has shown.
class LandmarkMarkers {
 public:
  explicit LandmarkMarkers(const MarkerStyle& style = MarkerStyle()) : style_(style) {}

  /// The markers of the current map. The array is reused between calls (no reallocation once it
  /// has grown). The first call after construction or reset() starts with a DELETEALL.
  const visualization_msgs::MarkerArray& build(const SlamPipeline& pipeline,
                                               const std::string& frame_id, const ros::Time& stamp);
  /// Forget what was shown (after a map reset or load): the next build() clears everything.
  void reset() {
    published_.clear();
    clear_all_ = true;
  }

  /// Marker namespaces.
  static constexpr const char* kLandmarks = "landmarks";
  static constexpr const char* kEllipses = "covariance_95";
  static constexpr const char* kIds = "ids";
  static constexpr const char* kTentative = "tentative";
  static constexpr const char* kVehicle = "vehicle";

 private:
  visualization_msgs::Marker& add();

  MarkerStyle style_;
  visualization_msgs::MarkerArray array_;
  std::size_t used_ = 0;
  std::unordered_set<LandmarkId> published_;
  std::unordered_set<LandmarkId> current_;
  bool clear_all_ = true;
};

}  // namespace ekf_slam
