// The bag an offline run replays, read up front (so that the processing loop measures the
// pipeline, not rosbag's decompression and deserialisation), every message through length checks;
// the sensors' poses on the vehicle from its static transforms; the true poses of a simulated bag.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <tf2/buffer_core.h>
#include <Eigen/Core>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/pipeline/odometry_input.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"
#include "ekf_slam/ros/offline/offline_options.h"

namespace ekf_slam {

struct ScanInput {
  double stamp;
  LaserScanData data;
  std::string frame_id;
};
struct ObservationsInput {
  double stamp;
  std::vector<Observation> observations;
  std::vector<std::int64_t> truth_ids;
  std::string frame_id;
};

// Everything the run needs from the bag, read up front so that the processing loop measures the
// pipeline, not rosbag's decompression and deserialisation.
// Order of the inputs in the bag (what a live node would receive).
struct Arrival {
  enum Kind : std::uint8_t { kOdometry, kScan, kObservations } kind;
  std::uint32_t index;  // into the vector of that kind
};
// A scan handed to the sequencer: which vector, which entry.
struct InputRef {
  bool observations = false;
  std::uint32_t index = 0;
};

struct BagContents {
  std::vector<Arrival> arrivals;
  std::vector<OdometryInput> odometry;
  std::vector<ScanInput> scans;
  std::vector<ObservationsInput> observation_sets;
  std::vector<StampedPoint> gps;
  std::vector<geometry_msgs::TransformStamped> tf_static;
  std::vector<std::pair<double, Eigen::Vector3d>> ground_truth;    // (stamp, true pose)
  std::vector<std::pair<std::int64_t, Eigen::Vector2d>> true_map;  // (truth id, position)
  bool has_truth_ids = false;
  std::uint64_t observations_without_truth = 0;  // in a bag that has truth ids
};

/// Reads the bag's topics (OfflineOptions names them). Throws std::runtime_error naming the bag
/// and, for a corrupted message, where it was and what was read before it.
BagContents readBag(const OfflineOptions& o);

// Sensor poses on the base frame per frame id, from the bag's static transforms (chains too),
// looked up once per frame with the node's rule (conversions.h, sensorOffset): a message whose
// frame has no transform (or no name) is skipped, counted and warned about, as the node does.
class SensorFrames {
 public:
  SensorFrames(const BagContents& c, const OfflineOptions& o, std::ostream& log);
  /// The offset of `frame`, or null (the message is skipped).
  const Eigen::Vector3d* offset(const std::string& frame);
  std::uint64_t skipped() const { return skipped_; }
  /// Every missing transform, for the error when no message could be used.
  const std::string& missing() const { return missing_; }

 private:
  const OfflineOptions& o_;
  std::ostream& log_;
  tf2::BufferCore buffer_;
  std::unordered_map<std::string, std::optional<Eigen::Vector3d>> offsets_;
  std::uint64_t skipped_ = 0;
  std::string missing_;
};

/// True pose at `stamp` from the ground-truth track (sorted by stamp): exact at a sample,
/// interpolated between two, none outside the track.
bool truePoseAt(const std::vector<std::pair<double, Eigen::Vector3d>>& track, double stamp,
                Eigen::Vector3d* pose);

}  // namespace ekf_slam
