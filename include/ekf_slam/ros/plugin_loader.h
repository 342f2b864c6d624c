// Creates plugins by their pluginlib name ("ekf_slam/DJNN", "ekf_slam/FGCBB") and configures them:
// one loader for every plugin family of the package (data associators, relocalisers, feature
// extractors), used by the SLAM node, the offline runner and the tools, so that all of them pick
// algorithms the same way.
//
//   AssociatorLoader loader;                       // = PluginLoader<DataAssociation>
//   auto djnn = loader.create("DJNN", params);     // bare names get the "ekf_slam/" prefix
//   RelocaliserLoader relocalisers;                // = PluginLoader<Relocaliser>
//
// A family is declared once in PluginFamily<Base> (base class name for pluginlib, a noun for
// messages, the default plugin); the loader itself is written once and instantiated for each
// family in plugin_loader.cpp.
//
// Lifetime: the plugin library stays loaded as long as the pluginlib loader lives. Every
// instance returned by create() holds a reference to the loader, so the library cannot be
// unloaded under a live instance, whatever the order in which the owner destroys things.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace pluginlib {
template <class T>
class ClassLoader;
}  // namespace pluginlib

namespace ekf_slam {

/// What pluginlib and the messages need to know about one plugin family.
template <class Base>
struct PluginFamily;

template <>
struct PluginFamily<DataAssociation> {
  static constexpr const char* kBaseClass = "ekf_slam::DataAssociation";
  static constexpr const char* kNoun = "associator";
  static constexpr const char* kDefault = kDefaultAssociator;
};

template <>
struct PluginFamily<Relocaliser> {
  static constexpr const char* kBaseClass = "ekf_slam::Relocaliser";
  static constexpr const char* kNoun = "relocaliser";
  /// Used when relocalisation is switched on without a name.
  static constexpr const char* kDefault = kDefaultRelocaliser;
};

template <>
struct PluginFamily<FeatureExtractor> {
  static constexpr const char* kBaseClass = "ekf_slam::FeatureExtractor";
  static constexpr const char* kNoun = "feature extractor";
  static constexpr const char* kDefault = kDefaultExtractor;
};

// UnknownPluginError (app/pipeline_builder.h): a name no plugin of the family declares.
using UnknownAssociatorError = UnknownPluginError;
using UnknownRelocaliserError = UnknownPluginError;

template <class Base>
class PluginLoader {
 public:
  /// The family's default plugin.
  static constexpr const char* kDefault = PluginFamily<Base>::kDefault;

  /// Reads the plugin descriptions exported by package ekf_slam. Throws std::runtime_error when
  /// the package cannot be found (the environment of devel/setup.bash is missing).
  PluginLoader();
  ~PluginLoader();
  PluginLoader(const PluginLoader&) = delete;
  PluginLoader& operator=(const PluginLoader&) = delete;

  /// Declared lookup names, sorted, e.g. {"ekf_slam/DJNN", "ekf_slam/Hungarian", ...}.
  std::vector<std::string> available() const;

  /// Full lookup name for `name`: a bare algorithm name ("DJNN") gets the "ekf_slam/" prefix.
  static std::string lookupName(const std::string& name);

  /// Creates the plugin `name` (see lookupName), unconfigured. Throws UnknownPluginError for an
  /// undeclared name, std::runtime_error when the plugin library cannot be loaded.
  std::shared_ptr<Base> instantiate(const std::string& name) const;
  /// The same, configured from `params` (ParameterError from configure()).
  std::shared_ptr<Base> create(const std::string& name, const ParameterSource& params) const;

 private:
  // Shared with every instance handed out (see the lifetime note above).
  std::shared_ptr<pluginlib::ClassLoader<Base>> loader_;
};

using AssociatorLoader = PluginLoader<DataAssociation>;
using RelocaliserLoader = PluginLoader<Relocaliser>;
using ExtractorLoader = PluginLoader<FeatureExtractor>;

/// The PluginFactory of the ROS shells and tools: every family through pluginlib, so that other
/// packages' plugins can be named too. Thread-compatible: callers serialise creation.
class PluginlibFactory : public PluginFactory {
 public:
  std::shared_ptr<DataAssociation> associator(const std::string& lookup) const override {
    return associators_.instantiate(lookup);
  }
  std::shared_ptr<Relocaliser> relocaliser(const std::string& lookup) const override {
    return relocalisers_.instantiate(lookup);
  }
  std::shared_ptr<FeatureExtractor> extractor(const std::string& lookup) const override {
    return extractors_.instantiate(lookup);
  }

 private:
  AssociatorLoader associators_;
  RelocaliserLoader relocalisers_;
  ExtractorLoader extractors_;
};

}  // namespace ekf_slam
