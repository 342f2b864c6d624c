// The scan filters of the chain, with laser_filters' type names and parameter names. Where
// laser_filters writes NaN or range_max + 1 into a filtered beam, these write +inf: the
// pipeline counts NaN as a faulty beam, and +inf is REP 117's "no return".
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"

#include <cmath>
#include <functional>
#include <limits>

#include "ekf_slam/core/common/recording_parameter_source.h"

namespace ekf_slam {
namespace {

constexpr float kNoReturn = std::numeric_limits<float>::infinity();

// A replacement value may be any number, +-inf or NaN (not checked for finiteness).
double replacement(const ParameterSource& params, const std::string& name) {
  double v = kNoReturn;
  params.get(name, &v);
  return v;
}

class RangeFilter : public ScanFilter {
 public:
  void configure(const ParameterSource& params) override {
    const ParameterReader r(params);
    use_message_limits_ = r.flag("use_message_range_limits", false);
    lower_ = r.nonNegative("lower_threshold", 0.0);
    upper_ = r.positive("upper_threshold", 100000.0);
    if (!(lower_ < upper_)) r.fail("lower_threshold", "must be < upper_threshold");
    lower_value_ = replacement(params, "lower_replacement_value");
    upper_value_ = replacement(params, "upper_replacement_value");
  }
  void apply(LaserScanData* scan, const Eigen::Vector3d&) const override {
    const double lower = use_message_limits_ ? scan->range_min : lower_;
    const double upper = use_message_limits_ ? scan->range_max : upper_;
    for (float& r : scan->ranges) {
      if (r <= lower) {
        r = static_cast<float>(lower_value_);
      } else if (r >= upper) {
        r = static_cast<float>(upper_value_);
      }
    }
  }

 private:
  bool use_message_limits_ = false;
  double lower_ = 0.0, upper_ = 0.0, lower_value_ = kNoReturn, upper_value_ = kNoReturn;
};

class AngularBoundsFilter : public ScanFilter {
 public:
  void configure(const ParameterSource& params) override {
    const ParameterReader r(params);
    lower_ = r.inRange("lower_angle", -M_PI, -2.0 * M_PI, 2.0 * M_PI);
    upper_ = r.inRange("upper_angle", M_PI, -2.0 * M_PI, 2.0 * M_PI);
    if (!(lower_ < upper_)) r.fail("lower_angle", "must be < upper_angle");
  }
  void apply(LaserScanData* scan, const Eigen::Vector3d&) const override {
    for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
      const double a = scan->angle_min + static_cast<double>(i) * scan->angle_increment;
      if (a < lower_ || a > upper_) scan->ranges[i] = kNoReturn;
    }
  }

 private:
  double lower_ = 0.0, upper_ = 0.0;
};

class IntensityFilter : public ScanFilter {
 public:
  void configure(const ParameterSource& params) override {
    const ParameterReader r(params);
    lower_ = r.number("lower_threshold", 8000.0);
    upper_ = r.number("upper_threshold", 100000.0);
    if (!(lower_ < upper_)) r.fail("lower_threshold", "must be < upper_threshold");
    invert_ = r.flag("invert", false);
    r.flag("disp_histogram", false);  // laser_filters' debugging output: accepted, no effect
  }
  bool needsIntensities() const override { return true; }
  void apply(LaserScanData* scan, const Eigen::Vector3d&) const override {
    for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
      const float v = scan->intensities[i];
      const bool inside = v > lower_ && v < upper_;  // laser_filters keeps the open interval
      if (inside == invert_) scan->ranges[i] = kNoReturn;
    }
  }

 private:
  double lower_ = 0.0, upper_ = 0.0;
  bool invert_ = false;
};

// The box is in the vehicle frame (base_link): a beam's end point is moved there with the
// laser's pose on the vehicle, so the box follows the vehicle's outline whatever the mounting.
class BoxFilter : public ScanFilter {
 public:
  void configure(const ParameterSource& params) override {
    const ParameterReader r(params);
    r.text("box_frame", "base_link");  // documentation only: the box is in the base frame
    min_ = Eigen::Vector2d(r.number("min_x", 0.0), r.number("min_y", 0.0));
    max_ = Eigen::Vector2d(r.number("max_x", 0.0), r.number("max_y", 0.0));
    r.number("min_z", 0.0);  // a planar scan has no height: accepted for laser_filters configs
    r.number("max_z", 0.0);
    if (!(min_.x() < max_.x())) r.fail("min_x", "must be < max_x");
    if (!(min_.y() < max_.y())) r.fail("min_y", "must be < max_y");
    invert_ = r.flag("invert", false);
  }
  void apply(LaserScanData* scan, const Eigen::Vector3d& offset) const override {
    const double c = std::cos(offset.z()), s = std::sin(offset.z());
    for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
      const float r = scan->ranges[i];
      if (!std::isfinite(r)) continue;
      const double a = scan->angle_min + static_cast<double>(i) * scan->angle_increment;
      const double lx = r * std::cos(a), ly = r * std::sin(a);
      const double x = offset.x() + c * lx - s * ly, y = offset.y() + s * lx + c * ly;
      const bool inside = x > min_.x() && x < max_.x() && y > min_.y() && y < max_.y();
      if (inside != invert_) scan->ranges[i] = kNoReturn;
    }
  }

 private:
  Eigen::Vector2d min_ = Eigen::Vector2d::Zero(), max_ = Eigen::Vector2d::Zero();
  bool invert_ = false;
};

using Factory = std::function<std::shared_ptr<ScanFilter>()>;

const std::map<std::string, Factory>& factories() {
  static const std::map<std::string, Factory> f = {
      {"laser_filters/LaserScanRangeFilter", [] { return std::make_shared<RangeFilter>(); }},
      {"laser_filters/LaserScanAngularBoundsFilterInPlace",
       [] { return std::make_shared<AngularBoundsFilter>(); }},
      {"laser_filters/LaserScanIntensityFilter",
       [] { return std::make_shared<IntensityFilter>(); }},
      {"laser_filters/LaserScanBoxFilter", [] { return std::make_shared<BoxFilter>(); }},
  };
  return f;
}

}  // namespace

std::vector<std::string> ScanFilterChain::knownTypes() {
  std::vector<std::string> out;
  for (const auto& kv : factories()) out.push_back(kv.first);
  return out;
}

void ScanFilterChain::add(const ScanFilterSpec& spec) {
  const std::string where = "scan_filter_chain/" + spec.name;
  if (spec.name.empty()) {
    throw ParameterError("parameter scan_filter_chain: entry " + std::to_string(size()) +
                         " has no name");
  }
  const auto it = factories().find(spec.type);
  if (it == factories().end()) {
    std::string known;
    for (const std::string& t : knownTypes()) known += (known.empty() ? "" : ", ") + t;
    throw ParameterError("parameter " + where + "/type: unknown scan filter type '" + spec.type +
                         "'; known: " + known);
  }
  std::shared_ptr<ScanFilter> filter = it->second();
  const MapParameterSource values(spec.params, where + "/params/");
  std::vector<std::string> names;
  for (const auto& kv : spec.params) names.push_back(kv.first);
  const RecordingParameterSource recorded(values, names);
  filter->configure(recorded);
  recorded.rejectUnread();
  filters_.push_back(std::move(filter));
  names_.push_back(spec.name);
}

ScanFilterChain ScanFilterChain::fromSpecs(const std::vector<ScanFilterSpec>& specs) {
  ScanFilterChain chain;
  for (const ScanFilterSpec& s : specs) chain.add(s);
  return chain;
}

bool ScanFilterChain::needsIntensities() const {
  for (const auto& f : filters_) {
    if (f->needsIntensities()) return true;
  }
  return false;
}

void ScanFilterChain::apply(LaserScanData* scan, const Eigen::Vector3d& sensor_offset) const {
  for (std::size_t i = 0; i < filters_.size(); ++i) {
    if (filters_[i]->needsIntensities()) {
      const std::string problem = intensityProblem(*scan);
      if (!problem.empty()) {
        throw ScanFormatError("scan filter '" + names_[i] + "' needs intensities: " + problem);
      }
    }
    filters_[i]->apply(scan, sensor_offset);
  }
}

}  // namespace ekf_slam
