// ParameterSource over a YAML mapping, for ROS-free tools (the replay tool, the offline runner).
//
// File layout: a mapping of scalars; parameters common to every associator at the top level,
// and optionally one sub-mapping per associator whose entries override them:
//
//   individual_probability: 0.95      # any associator
//   DJNN:
//     sensor_range: 30.0        # DJNN only
//
// Read with section "DJNN", both entries are visible; read with section "JCBB", only the first.
// Scope::kSectionOnly reads the section alone, as a node reads its ~DJNN namespace: the offline
// runner uses it so that one file (pipeline parameters at the top level, each associator's
// under its name) configures the runner exactly as rosparam-loaded into the node.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class YamlParameterSource : public ParameterSource {
 public:
  /// Which entries a source with a section sees.
  enum class Scope {
    kTopLevelAndSection,  ///< top-level scalars, overridden by the section's entries
    kSectionOnly,         ///< the section's entries only (none when the section is absent)
  };

  /// Empty: every get() returns false.
  YamlParameterSource() = default;
  /// Throws std::runtime_error when the file cannot be read or parsed or is not a mapping.
  static YamlParameterSource fromFile(const std::string& path, const std::string& section = "",
                                      Scope scope = Scope::kTopLevelAndSection);
  /// `origin` names the text in error messages.
  static YamlParameterSource fromString(const std::string& text, const std::string& section = "",
                                        const std::string& origin = "<yaml>",
                                        Scope scope = Scope::kTopLevelAndSection);

  bool get(const std::string& name, double* value) const override;
  bool get(const std::string& name, int* value) const override;
  bool get(const std::string& name, bool* value) const override;
  bool get(const std::string& name, std::string* value) const override;
  /// "<origin>:<section>/<name>", or "<origin>:<name>" for a top-level entry.
  std::string qualify(const std::string& name) const override;
  /// The scalar entries this source sees (top level and/or its section, by its scope).
  std::vector<std::string> names() const;

  /// Sets or overrides a parameter (a YAML scalar, e.g. "0.95").
  void set(const std::string& name, const std::string& scalar);
  bool contains(const std::string& name) const { return values_.count(name) > 0; }

 private:
  YamlParameterSource(const YAML::Node& root, const std::string& section, const std::string& origin,
                      Scope scope);
  template <typename T>
  bool read(const std::string& name, const char* expected, T* value) const;

  struct Entry {
    YAML::Node node;
    bool in_section;
  };
  std::map<std::string, Entry> values_;
  std::string origin_ = "<yaml>";
  std::string section_;
};

}  // namespace ekf_slam
