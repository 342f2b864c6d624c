// A Configuration from a YAML file (the layout of config/*.yaml: pipeline and node parameters at
// the top level, each plugin's under its short name, `scan_filter_chain` as a list), with the
// layers the tools put around it: defaults where the file is silent (evaluate's world values, a
// replayed problem's gates) and overrides that replace it (command-line options such as
// --associator or --set).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ekf_slam/app/configuration.h"

namespace ekf_slam {

class YamlConfiguration : public Configuration {
 public:
  /// `path` empty: no file (every default). Throws std::runtime_error when the file cannot be
  /// read or parsed.
  explicit YamlConfiguration(const std::string& path = "");
  /// The same from YAML text; `origin` names it in errors.
  static YamlConfiguration fromText(const std::string& text, const std::string& origin = "<yaml>");

  /// A value used where the file does not set `name`; `section` "" is the top level.
  void setDefault(const std::string& section, const std::string& name, const std::string& value);
  /// A value that replaces the file's; `section` "" is the top level.
  void setOverride(const std::string& section, const std::string& name, const std::string& value);

  ParameterSection top() const override;
  ParameterSection section(const std::string& short_name) const override;
  std::vector<ScanFilterSpec> scanFilterChain() const override;
  const std::string& path() const { return path_; }

 private:
  using Values = std::map<std::string, std::map<std::string, std::string>>;  // section -> values
  ParameterSection layered(const std::string& section) const;

  std::string path_;  // where the text comes from (errors name it); empty: no text
  std::string text_;  // the file, read once
  Values defaults_, overrides_;
};

}  // namespace ekf_slam
