#include "ekf_slam/app/yaml_configuration.h"

#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "ekf_slam/app/scan_filter_yaml.h"
#include "ekf_slam/app/yaml_parameter_source.h"

namespace ekf_slam {

YamlConfiguration::YamlConfiguration(const std::string& path) : path_(path) {
  if (path.empty()) return;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read parameters from " + path + ": cannot open it");
  std::ostringstream text;
  text << in.rdbuf();
  text_ = text.str();
  YamlParameterSource::fromString(text_, "", path);  // a parse error fails here, once
}

YamlConfiguration YamlConfiguration::fromText(const std::string& text, const std::string& origin) {
  YamlConfiguration c;
  c.path_ = origin;
  c.text_ = text;
  YamlParameterSource::fromString(c.text_, "", origin);
  return c;
}

void YamlConfiguration::setDefault(const std::string& section, const std::string& name,
                                   const std::string& value) {
  defaults_[section][name] = value;
}

void YamlConfiguration::setOverride(const std::string& section, const std::string& name,
                                    const std::string& value) {
  overrides_[section][name] = value;
}

ParameterSection YamlConfiguration::layered(const std::string& section) const {
  auto source = std::make_shared<YamlParameterSource>(
      path_.empty() ? YamlParameterSource()
                    : YamlParameterSource::fromString(text_, section, path_,
                                                      YamlParameterSource::Scope::kSectionOnly));
  if (const auto d = defaults_.find(section); d != defaults_.end()) {
    for (const auto& [name, value] : d->second) {
      if (!source->contains(name)) source->set(name, value);
    }
  }
  if (const auto o = overrides_.find(section); o != overrides_.end()) {
    for (const auto& [name, value] : o->second) source->set(name, value);
  }
  return {source, source->names()};
}

ParameterSection YamlConfiguration::top() const { return layered(""); }

ParameterSection YamlConfiguration::section(const std::string& short_name) const {
  if (short_name.empty()) throw std::invalid_argument("a plugin section needs a name");
  return layered(short_name);
}

std::vector<ScanFilterSpec> YamlConfiguration::scanFilterChain() const {
  return path_.empty() ? std::vector<ScanFilterSpec>() : readScanFilterChainText(text_, path_);
}

}  // namespace ekf_slam
