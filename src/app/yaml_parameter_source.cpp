#include "ekf_slam/app/yaml_parameter_source.h"

#include <stdexcept>

namespace ekf_slam {

YamlParameterSource::YamlParameterSource(const YAML::Node& root, const std::string& section,
                                         const std::string& origin, Scope scope)
    : origin_(origin), section_(section) {
  if (!root || root.IsNull()) return;  // an empty file sets nothing
  if (!root.IsMap()) throw std::runtime_error(origin + ": expected a mapping of parameters");
  if (scope == Scope::kTopLevelAndSection || section.empty()) {
    for (const auto& kv : root) {
      // Sub-mappings are other associators' sections; only ours is read, below.
      if (kv.second.IsMap()) continue;
      values_[kv.first.as<std::string>()] = Entry{kv.second, false};
    }
  }
  if (section.empty() || !root[section]) return;
  const YAML::Node sub = root[section];
  if (!sub.IsMap()) throw std::runtime_error(origin + ": '" + section + "' is not a mapping");
  for (const auto& kv : sub) values_[kv.first.as<std::string>()] = Entry{kv.second, true};
}

YamlParameterSource YamlParameterSource::fromFile(const std::string& path,
                                                  const std::string& section, Scope scope) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot read parameters from " + path + ": " + e.what());
  }
  return YamlParameterSource(root, section, path, scope);
}

YamlParameterSource YamlParameterSource::fromString(const std::string& text,
                                                    const std::string& section,
                                                    const std::string& origin, Scope scope) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot parse parameters in " + origin + ": " + e.what());
  }
  return YamlParameterSource(root, section, origin, scope);
}

std::string YamlParameterSource::qualify(const std::string& name) const {
  const auto it = values_.find(name);
  const bool in_section = it != values_.end() && it->second.in_section;
  return origin_ + ":" + (in_section ? section_ + "/" : "") + name;
}

std::vector<std::string> YamlParameterSource::names() const {
  std::vector<std::string> out;
  for (const auto& kv : values_) out.push_back(kv.first);
  return out;
}

void YamlParameterSource::set(const std::string& name, const std::string& scalar) {
  values_[name] = Entry{YAML::Node(scalar), false};
}

template <typename T>
bool YamlParameterSource::read(const std::string& name, const char* expected, T* value) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return false;
  const YAML::Node& node = it->second.node;
  if (!node.IsScalar()) {
    throw ParameterError("parameter " + qualify(name) + ": expected " + expected + ", got " +
                         (node.IsSequence() ? "a list"
                          : node.IsNull()   ? "nothing"
                                            : "a mapping"));
  }
  try {
    *value = node.as<T>();
  } catch (const YAML::Exception&) {
    throw ParameterError("parameter " + qualify(name) + ": expected " + expected + ", got '" +
                         node.Scalar() + "'");
  }
  return true;
}

bool YamlParameterSource::get(const std::string& name, double* value) const {
  return read(name, "a number", value);
}
bool YamlParameterSource::get(const std::string& name, int* value) const {
  return read(name, "an integer", value);
}
bool YamlParameterSource::get(const std::string& name, bool* value) const {
  return read(name, "true or false", value);
}
bool YamlParameterSource::get(const std::string& name, std::string* value) const {
  return read(name, "a string", value);
}

}  // namespace ekf_slam
