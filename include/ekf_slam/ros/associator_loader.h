// Creates data associators by their pluginlib name ("ekf_slam/DJNN") and configures them. Used by
// the SLAM node and the replay tool, so that both pick algorithms exactly the same way.
//
// Lifetime: the plugin library stays loaded as long as the pluginlib loader lives. Every
// associator returned by create() holds a reference to the loader, so the library cannot be
// unloaded under a live instance, whatever the order in which the owner destroys things.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "ekf_slam/core/data_association.h"
#include "ekf_slam/core/parameters.h"

namespace pluginlib {
template <class T>
class ClassLoader;
}  // namespace pluginlib

namespace ekf_slam {

/// Thrown for a name no plugin declares; the message lists the declared names.
class UnknownAssociatorError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class AssociatorLoader {
 public:
  /// The default associator.
  static constexpr const char* kDefault = "ekf_slam/DJNN";

  /// Reads the plugin descriptions exported by package ekf_slam. Throws std::runtime_error when
  /// the package cannot be found (the environment of devel/setup.bash is missing).
  AssociatorLoader();
  ~AssociatorLoader();
  AssociatorLoader(const AssociatorLoader&) = delete;
  AssociatorLoader& operator=(const AssociatorLoader&) = delete;

  /// Declared lookup names, sorted, e.g. {"ekf_slam/DJNN", "ekf_slam/Hungarian", ...}.
  std::vector<std::string> available() const;

  /// Full lookup name for `name`: a bare algorithm name ("DJNN") gets the "ekf_slam/" prefix.
  static std::string lookupName(const std::string& name);

  /// Creates the associator `name` (see lookupName) and configures it from `params`.
  /// Throws UnknownAssociatorError for an undeclared name, std::runtime_error when the plugin
  /// library cannot be loaded, ParameterError from configure().
  std::shared_ptr<DataAssociation> create(const std::string& name,
                                          const ParameterSource& params) const;

 private:
  // Shared with every instance handed out (see the lifetime note above).
  std::shared_ptr<pluginlib::ClassLoader<DataAssociation>> loader_;
};

}  // namespace ekf_slam
