// The feature-extraction plugin interface: one laser scan in, point landmarks out (range,
// bearing, R, descriptor in the sensor frame). TreeExtractor (ACFR's trunk detector, the
// default) and BeaconExtractor (retro-reflective beacons from intensities) implement it; the ROS
// side loads them with pluginlib by name ("ekf_slam/TreeExtractor"), like the associators, and
// SlamPipeline calls the one it was given on every scan. See docs/feature_extraction.md.
#pragma once

#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/observation.h"

namespace ekf_slam {

/// One scan's data as sensor_msgs/LaserScan carries it, without ROS. Beam i is at angle
/// angle_min + i * angle_increment (counter-clockwise positive, 0 = the sensor's x axis).
struct LaserScanData {
  std::vector<float> ranges;
  /// Empty when the sensor reports none; otherwise one per beam.
  std::vector<float> intensities;
  double angle_min = 0.0;
  double angle_increment = 0.0;
  double range_min = 0.0;
  double range_max = std::numeric_limits<double>::infinity();
  /// sensor_msgs/LaserScan's angle_max, when known: the geometry is then checked against the
  /// number of beams (scanGeometryError).
  std::optional<double> angle_max;

  bool hasIntensities() const { return !intensities.empty(); }
};

/// Thrown for a scan an extractor cannot use at all (e.g. no intensity channel for an extractor
/// that needs one): a configuration error, not "nothing seen".
class ScanFormatError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The plugin interface. pluginlib needs a default constructor, so parameters come in configure().
class FeatureExtractor {
 public:
  virtual ~FeatureExtractor() = default;

  /// Reads and validates every parameter (throws ParameterError naming a bad one).
  virtual void configure(const ParameterSource& params) = 0;
  /// Short name, e.g. "TreeExtractor".
  virtual std::string name() const = 0;
  /// True when extract() needs the intensity channel (the shells say so at start-up).
  virtual bool needsIntensities() const { return false; }
  /// How far in front of a feature's reported position its own surface can return a beam (a
  /// trunk's or a beacon's largest radius) [m]: a nearer return at its bearing hides it
  /// (ScanOcclusion). The default, 0, is a point.
  virtual double featureRadius() const { return 0.0; }
  /// The radius of the thinnest feature reported, when the configuration states it (a beacon
  /// pole's) [m]. Beyond the range where the beams are farther apart than that, such a feature is
  /// hit in only some scans (ScanOcclusion::hitProbability). The default, 0, is unknown: every
  /// feature in view is taken to be hit.
  virtual double thinnestFeatureRadius() const { return 0.0; }

  /// Throws ScanFormatError when the scan cannot be used by this extractor at all (checked
  /// before the scan changes any state). The default accepts every scan.
  virtual void checkScan(const LaserScanData& scan) const;

  /// The landmarks of one scan. An observation whose R is all zeros gets the pipeline's default
  /// noise (sigma_range, sigma_bearing). Non-finite or negative ranges count as no return.
  /// Must be safe to call from one thread at a time; may keep scratch buffers.
  virtual std::vector<Observation> extract(const LaserScanData& scan) const = 0;
};

/// The base of every wrapper of a feature extractor: forwards every virtual above, so a wrapper
/// overrides only what it adds (test_plugin_forwarding counts them).
class ForwardingFeatureExtractor : public FeatureExtractor {
 public:
  explicit ForwardingFeatureExtractor(std::shared_ptr<FeatureExtractor> inner)
      : inner_(std::move(inner)) {}

  void configure(const ParameterSource& params) override { inner_->configure(params); }
  std::string name() const override { return inner_->name(); }
  bool needsIntensities() const override { return inner_->needsIntensities(); }
  double featureRadius() const override { return inner_->featureRadius(); }
  double thinnestFeatureRadius() const override { return inner_->thinnestFeatureRadius(); }
  void checkScan(const LaserScanData& scan) const override { inner_->checkScan(scan); }
  std::vector<Observation> extract(const LaserScanData& scan) const override {
    return inner_->extract(scan);
  }

 private:
  std::shared_ptr<FeatureExtractor> inner_;
};

/// Reads `name` from `primary`, else `fallback_prefix + name` from `fallback`: how TreeExtractor's
/// section (~TreeExtractor/max_range) falls back on its historical top-level names
/// (extractor_max_range), so that existing configs keep working.
class FallbackParameterSource : public ParameterSource {
 public:
  FallbackParameterSource(const ParameterSource& primary, const ParameterSource& fallback,
                          std::string fallback_prefix)
      : primary_(primary), fallback_(fallback), prefix_(std::move(fallback_prefix)) {}
  bool get(const std::string& name, double* value) const override { return pass(name, value); }
  bool get(const std::string& name, int* value) const override { return pass(name, value); }
  bool get(const std::string& name, bool* value) const override { return pass(name, value); }
  bool get(const std::string& name, std::string* value) const override { return pass(name, value); }
  std::string qualify(const std::string& name) const override { return primary_.qualify(name); }

 private:
  template <typename T>
  bool pass(const std::string& name, T* value) const {
    return primary_.get(name, value) || fallback_.get(prefix_ + name, value);
  }
  const ParameterSource& primary_;
  const ParameterSource& fallback_;
  std::string prefix_;
};

/// Names the scan's problem for an extractor that needs intensities (empty: fine).
std::string intensityProblem(const LaserScanData& scan);

}  // namespace ekf_slam
