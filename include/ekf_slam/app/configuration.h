// Where an entry point's configuration comes from: the top-level parameters (the pipeline's, the
// node's, the plugin names), one section per plugin (e.g. DJNN's parameters under `DJNN`), and
// the scan filter chain. The node reads it from the parameter server (RosConfiguration), the
// offline runner and the tools from a YAML file (YamlConfiguration); buildPipeline reads both the
// same way.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"

namespace ekf_slam {

/// Parameters and the names they hold: what nobody read of `names` is a misspelling.
struct ParameterSection {
  std::shared_ptr<const ParameterSource> source;  ///< never null
  std::vector<std::string> names;
};

class Configuration {
 public:
  virtual ~Configuration() = default;
  /// The top-level parameters.
  virtual ParameterSection top() const = 0;
  /// The section of plugin `short_name` ("DJNN", "FGCBB", "BeaconExtractor"): its entries only
  /// (an absent section holds none).
  virtual ParameterSection section(const std::string& short_name) const = 0;
  /// `scan_filter_chain` (a list of {name, type, params}); empty when unset.
  virtual std::vector<ScanFilterSpec> scanFilterChain() const = 0;
};

}  // namespace ekf_slam
