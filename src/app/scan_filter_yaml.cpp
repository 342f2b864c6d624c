#include "ekf_slam/app/scan_filter_yaml.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace ekf_slam {
namespace {

std::string scalar(const YAML::Node& node, const std::string& where) {
  if (!node || !node.IsScalar()) throw ParameterError("parameter " + where + ": must be a scalar");
  return node.Scalar();
}

std::vector<ScanFilterSpec> fromRoot(const YAML::Node& root, const std::string& origin) {
  std::vector<ScanFilterSpec> out;
  if (!root || !root.IsMap() || !root["scan_filter_chain"]) return out;
  const YAML::Node list = root["scan_filter_chain"];
  const std::string where = origin + ":scan_filter_chain";
  if (list.IsNull()) return out;
  if (!list.IsSequence()) {
    throw ParameterError("parameter " + where + ": must be a list of {name, type, params}");
  }
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node entry = list[i];
    const std::string at = where + "[" + std::to_string(i) + "]";
    if (!entry.IsMap()) throw ParameterError("parameter " + at + ": must be a mapping");
    ScanFilterSpec spec;
    spec.name = scalar(entry["name"], at + "/name");
    spec.type = scalar(entry["type"], at + "/type");
    for (const auto& kv : entry) {
      const std::string key = kv.first.as<std::string>();
      if (key != "name" && key != "type" && key != "params") {
        throw ParameterError("parameter " + at + "/" + key +
                             ": unknown key (an entry has name, type, params)");
      }
    }
    const YAML::Node params = entry["params"];
    if (params && !params.IsNull()) {
      if (!params.IsMap()) throw ParameterError("parameter " + at + "/params: must be a mapping");
      for (const auto& kv : params) {
        const std::string key = kv.first.as<std::string>();
        spec.params[key] = scalar(kv.second, at + "/params/" + key);
      }
    }
    out.push_back(std::move(spec));
  }
  return out;
}

}  // namespace

std::vector<ScanFilterSpec> readScanFilterChainFile(const std::string& path) {
  if (path.empty()) return {};
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read parameters from " + path);
  std::stringstream text;
  text << in.rdbuf();  // an empty file is no chain (failbit set, nothing read)
  return readScanFilterChainText(text.str(), path);
}

std::vector<ScanFilterSpec> readScanFilterChainText(const std::string& text,
                                                    const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot parse parameters in " + origin + ": " + e.what());
  }
  return fromRoot(root, origin);
}

}  // namespace ekf_slam
