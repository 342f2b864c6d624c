// The relocalisation plugin interface: find the vehicle's pose in a known map from one scan's
// observations, with or without a pose prior. FGCBB / GCBB (seed 001, paper 2) and RRW&SC
// (seed 004) implement it; the ROS side loads them with pluginlib by name ("ekf_slam/FGCBB"),
// like the associators, and SlamPipeline calls them when the filter is lost.
//
// Contract: a relocaliser never answers kFound with a wrong pose it cannot tell from another
// one. When the best hypothesis is not clearly better than the runner-up (a regular grid, a
// mirror-symmetric map, too few observations), the answer is kAmbiguous.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/ekf_slam.h"  // LandmarkId
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/filter/scan_window.h"

namespace ekf_slam {

/// One landmark of the map a relocaliser searches.
struct MapLandmark {
  LandmarkId id = kNoLandmark;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< map frame [m]
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  /// Optional descriptor, e.g. the trunk diameter [m]; NaN when unknown.
  double descriptor = std::numeric_limits<double>::quiet_NaN();
};

/// A prior on the vehicle pose (map frame), e.g. the filter's own estimate.
struct PosePrior {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

enum class RelocalisationStatus : std::uint8_t {
  kFound,      ///< one hypothesis, clearly the best: pose and pairings are valid
  kNotFound,   ///< no hypothesis passes the tests (or too few observations / landmarks)
  kAmbiguous,  ///< several hypotheses explain the scan about equally well: no pose
};
const char* toString(RelocalisationStatus s);

struct RelocalisationResult {
  RelocalisationStatus status = RelocalisationStatus::kNotFound;
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();  ///< vehicle (base_link) pose in the map frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// One per observation: the map landmark id it was paired with, or kNoLandmark.
  std::vector<LandmarkId> landmark;
  double joint_mahalanobis = std::numeric_limits<double>::quiet_NaN();  ///< of the hypothesis
  int hypothesis_size = 0;                                              ///< number of pairings
  std::uint64_t nodes = 0;  ///< search nodes (or iterations) spent
  std::string reason;       ///< why kNotFound / kAmbiguous, for logs
};

/// The plugin interface. pluginlib needs a default constructor, so parameters come in configure().
class Relocaliser {
 public:
  virtual ~Relocaliser() = default;

  /// Reads and validates every parameter (throws ParameterError naming a bad one).
  virtual void configure(const ParameterSource& params) = 0;
  /// Short name, e.g. "FGCBB".
  virtual std::string name() const = 0;

  /// The map to search. Called when the map changes (rarely compared with relocalise()), so an
  /// implementation may precompute here (pair distances, spatial index).
  virtual void setMap(const std::vector<MapLandmark>& map) = 0;

  /// Finds the vehicle pose from one scan's observations (range, bearing, R, descriptor in the
  /// sensor frame; the sensor sits at `sensor_offset` = (x, y, yaw) on base_link). `prior` is
  /// null for a global search.
  virtual RelocalisationResult relocalise(const std::vector<Observation>& observations,
                                          const Eigen::Vector3d& sensor_offset,
                                          const PosePrior* prior) = 0;

  /// The same from a window of scans (oldest first, the current one last), each carried into the
  /// current base_link by odometry (CarriedScan). The answer's pose is the current base_link's;
  /// `landmark` has one entry per observation of every scan, in that order. The default searches
  /// the current scan alone (the older ones stay unpaired); FGCBB / GCBB use them all.
  virtual RelocalisationResult relocaliseWindow(const std::vector<CarriedScan>& scans,
                                                const Eigen::Vector3d& sensor_offset,
                                                const PosePrior* prior);
};

/// The base of every wrapper of a relocaliser: forwards every virtual above, so a wrapper
/// overrides only what it adds (test_plugin_forwarding counts them).
class ForwardingRelocaliser : public Relocaliser {
 public:
  explicit ForwardingRelocaliser(std::shared_ptr<Relocaliser> inner) : inner_(std::move(inner)) {}

  void configure(const ParameterSource& params) override { inner_->configure(params); }
  std::string name() const override { return inner_->name(); }
  void setMap(const std::vector<MapLandmark>& map) override { inner_->setMap(map); }
  RelocalisationResult relocalise(const std::vector<Observation>& observations,
                                  const Eigen::Vector3d& sensor_offset,
                                  const PosePrior* prior) override {
    return inner_->relocalise(observations, sensor_offset, prior);
  }
  RelocalisationResult relocaliseWindow(const std::vector<CarriedScan>& scans,
                                        const Eigen::Vector3d& sensor_offset,
                                        const PosePrior* prior) override {
    return inner_->relocaliseWindow(scans, sensor_offset, prior);
  }

 private:
  std::shared_ptr<Relocaliser> inner_;
};

}  // namespace ekf_slam
