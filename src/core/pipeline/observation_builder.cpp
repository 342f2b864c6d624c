#include "ekf_slam/core/pipeline/observation_builder.h"

#include <cmath>
#include <utility>

#include <Eigen/LU>  // determinant

#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

namespace ekf_slam {

namespace {

// The default covariance is (sigma_range, sigma_bearing); a Cartesian observation gets it
// carried to (x, y) at its own point, J R J^T with J = d(x, y) / d(range, bearing).
Eigen::Matrix2d defaultCovariance(const Observation& o, const Eigen::Matrix2d& R_range_bearing) {
  if (o.kind != MeasurementKind::kCartesian) return R_range_bearing;
  const double r = o.z.norm();
  const double c = r > 0.0 ? o.z.x() / r : 1.0;
  const double s = r > 0.0 ? o.z.y() / r : 0.0;
  Eigen::Matrix2d J;
  J << c, -r * s, s, r * c;
  return J * R_range_bearing * J.transpose();
}

}  // namespace

ObservationBuilder::ObservationBuilder(const PipelineConfig& config, PipelineCounters& counters)
    : config_(config),
      counters_(counters),
      extractor_(std::make_shared<TreeFeatureExtractor>(config.extractor)) {}

void ObservationBuilder::setExtractor(std::shared_ptr<FeatureExtractor> extractor) {
  extractor_ =
      extractor ? std::move(extractor) : std::make_shared<TreeFeatureExtractor>(config_.extractor);
}

void ObservationBuilder::reset() {
  last_scan_stamp_ = std::numeric_limits<double>::quiet_NaN();
  last_scan_ranges_.clear();
}

const LaserScanData& ObservationBuilder::filtered(const LaserScanData& input,
                                                  const Eigen::Vector3d& sensor_offset) {
  const LaserScanData* scan = &input;
  if (!scan_filter_.empty()) {
    filtered_scan_ = input;
    scan_filter_.apply(&filtered_scan_, sensor_offset);
    scan = &filtered_scan_;
  }
  extractor_->checkScan(*scan);
  return *scan;
}

bool ObservationBuilder::repeats(double stamp, const LaserScanData& input) {
  if (stamp == last_scan_stamp_ && input.angle_min == last_scan_angle_min_ &&
      input.angle_increment == last_scan_angle_increment_ && input.ranges == last_scan_ranges_) {
    ++counters_.duplicate_scans;
    return true;
  }
  last_scan_stamp_ = stamp;
  last_scan_angle_min_ = input.angle_min;
  last_scan_angle_increment_ = input.angle_increment;
  last_scan_ranges_ = input.ranges;
  return false;
}

bool ObservationBuilder::extract(const LaserScanData& scan, std::vector<Observation>* observations,
                                 ScanReport* report) {
  int invalid = 0;
  for (const float r : scan.ranges) {
    // +inf is a valid "no return" (REP 117); NaN and negative values are not.
    if (std::isnan(r) || r < 0.0f) ++invalid;
  }
  counters_.invalid_ranges += invalid;
  const bool usable = !scan.ranges.empty() && invalid < static_cast<int>(scan.ranges.size()) &&
                      std::isfinite(scan.angle_min) && std::isfinite(scan.angle_increment) &&
                      scan.angle_increment != 0.0;
  if (!usable) return false;
  const Eigen::Matrix2d R = Eigen::Vector2d(config_.sigma_range * config_.sigma_range,
                                            config_.sigma_bearing * config_.sigma_bearing)
                                .asDiagonal();
  for (Observation& o : extractor_->extract(scan)) {
    const double range = o.z(0);
    if (!(range >= config_.min_observation_range && range <= config_.max_observation_range))
      continue;
    if (o.R.isZero(0.0)) {
      o.R = R;
      o.default_covariance = true;
    }
    // A plugin's output is checked like any external observation.
    if (!(o.z.allFinite() && o.R.allFinite() && o.R(0, 0) > 0.0 && o.R(1, 1) > 0.0 &&
          o.R.determinant() > 0.0 && !std::isinf(o.descriptor))) {
      ++report->invalid_observations;
      continue;
    }
    observations->push_back(o);
  }
  counters_.invalid_observations += report->invalid_observations;
  return true;
}

std::vector<Observation> ObservationBuilder::check(std::vector<Observation> observations,
                                                   ScanReport* report) {
  const Eigen::Matrix2d R_default = Eigen::Vector2d(config_.sigma_range * config_.sigma_range,
                                                    config_.sigma_bearing * config_.sigma_bearing)
                                        .asDiagonal();
  std::size_t kept = 0;
  report->input_index.reserve(observations.size());
  for (std::size_t i = 0; i < observations.size(); ++i) {
    Observation o = observations[i];
    if (o.R.isZero(0.0)) {
      o.R = defaultCovariance(o, R_default);
      o.default_covariance = true;
    }
    const bool ok = o.z.allFinite() && (o.kind == MeasurementKind::kCartesian || o.z(0) >= 0.0) &&
                    o.R.allFinite() && o.R(0, 0) > 0.0 && o.R(1, 1) > 0.0 &&
                    o.R.determinant() > 0.0 && !std::isinf(o.descriptor);
    if (!ok) {
      ++report->invalid_observations;
      continue;
    }
    observations[kept++] = o;
    report->input_index.push_back(static_cast<std::uint32_t>(i));
  }
  observations.resize(kept);
  counters_.invalid_observations += report->invalid_observations;
  return observations;
}

}  // namespace ekf_slam
