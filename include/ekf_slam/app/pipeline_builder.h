// Parameters -> a configured pipeline, in one place for every entry point (the node, the offline
// runner, evaluate, relocalisation_experiment, detect_trees, replay_association):
//
//   top level   node settings (readNodeConfig), pipeline settings (readPipelineConfig),
//               `associator`, `extractor`, `relocaliser` (plugin names), `scan_filter_chain`
//   sections    each chosen plugin reads its own section only ("DJNN:", "FGCBB:", ...);
//               TreeExtractor falls back on its historical top-level names (extractor_*)
//
// Every name a section or the top level holds must be read by someone: a misspelt key is a
// ParameterError naming it (and the nearest known name) wherever the configuration comes from.
// ROS-free: plugins come from a PluginFactory (pluginlib in the ROS shells, ros/plugin_loader.h).
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "ekf_slam/app/configuration.h"
#include "ekf_slam/app/node_config.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

/// The plugins used when the configuration names none (the relocaliser's, kDefaultRelocaliser,
/// is in core/pipeline/pipeline_config.h; see defaultRelocaliserFor).
constexpr const char* kDefaultAssociator = "ekf_slam/DJNN";
constexpr const char* kDefaultExtractor = "ekf_slam/TreeExtractor";

/// "DJNN" -> "ekf_slam/DJNN" (a name without a package gets ours); full names are kept.
std::string pluginLookupName(const std::string& name);
/// "ekf_slam/DJNN" -> "DJNN": the plugin's section (and its name in reports).
std::string pluginShortName(const std::string& name);

/// The relocaliser an associator brings (lookup names): an associator that recognises landmarks
/// without the pose brings the relocaliser built on the same matcher (ekf_slam/RRWSC ->
/// ekf_slam/RRWSC); every other associator kDefaultRelocaliser. Used when `relocaliser` is not
/// set (docs/relocalisation.md, "Which relocaliser").
std::string defaultRelocaliserFor(const std::string& associator);

/// The relocaliser a configuration asks for, as a lookup name; empty: recovery off. `relocaliser`
/// when it is set, also to "" (off); else the one `associator` brings. buildPipeline's rule, for
/// a tool that must know before building (evaluate gives that plugin's section the world's values).
std::string relocaliserName(const Configuration& configuration);

/// Creates plugins, unconfigured, by lookup name ("ekf_slam/DJNN"). Throws UnknownPluginError
/// (listing the names it knows) for a name it does not know.
class PluginFactory {
 public:
  virtual ~PluginFactory() = default;
  virtual std::shared_ptr<DataAssociation> associator(const std::string& lookup) const = 0;
  virtual std::shared_ptr<Relocaliser> relocaliser(const std::string& lookup) const = 0;
  virtual std::shared_ptr<FeatureExtractor> extractor(const std::string& lookup) const = 0;
};

/// Thrown for a plugin name no factory knows; the message lists the known names.
class UnknownPluginError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Everything a configuration gives a pipeline, every plugin configured.
struct PipelineParts {
  NodeConfig node;  ///< validated everywhere, used by the node
  PipelineConfig config;
  std::string associator_name;  ///< lookup names
  std::string extractor_name;
  std::string relocaliser_name;  ///< empty: recovery off (relocaliserName); also config.relocaliser
  std::shared_ptr<DataAssociation> associator;
  std::shared_ptr<FeatureExtractor> extractor;
  std::shared_ptr<Relocaliser> relocaliser;  ///< null: recovery off
  ScanFilterChain scan_filter;
};

/// Reads and validates the whole configuration and creates the plugins. Throws ParameterError
/// (a bad value, or names nobody reads), UnknownPluginError, and what a plugin's configure()
/// throws.
PipelineParts buildPipeline(const Configuration& configuration, const PluginFactory& plugins);

/// A pipeline with the parts' settings, associator, extractor, scan filters and relocaliser.
std::unique_ptr<SlamPipeline> makePipeline(const PipelineParts& parts);

}  // namespace ekf_slam
