#include "ekf_slam/ros/extractor_loader.h"

#include <sstream>

#include <xmlrpcpp/XmlRpcValue.h>

namespace ekf_slam {

LaserScanData toScanData(const sensor_msgs::LaserScan& scan) {
  LaserScanData d;
  d.ranges = scan.ranges;
  d.intensities = scan.intensities;
  d.angle_min = scan.angle_min;
  d.angle_increment = scan.angle_increment;
  d.angle_max = scan.angle_max;  // the geometry is checked against it (scanGeometryError)
  d.range_min = scan.range_min;
  // A driver that leaves range_max at 0 means "not given", not "nothing is valid".
  if (scan.range_max > 0.0f) d.range_max = scan.range_max;
  return d;
}

namespace {

std::string scalarText(XmlRpc::XmlRpcValue& v, const std::string& where) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream os;
      os.precision(17);
      os << static_cast<double>(v);
      return os.str();
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(v);
    default:
      throw ParameterError("parameter " + where + ": must be a scalar");
  }
}

}  // namespace

std::vector<ScanFilterSpec> readScanFilterChain(const ros::NodeHandle& nh, const std::string& key) {
  std::vector<ScanFilterSpec> out;
  XmlRpc::XmlRpcValue list;
  if (!nh.getParam(key, list)) return out;
  const std::string where = nh.resolveName(key);
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    throw ParameterError("parameter " + where + ": must be a list of {name, type, params}");
  }
  for (int i = 0; i < list.size(); ++i) {
    XmlRpc::XmlRpcValue& entry = list[i];
    const std::string at = where + "[" + std::to_string(i) + "]";
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct || !entry.hasMember("name") ||
        !entry.hasMember("type")) {
      throw ParameterError("parameter " + at + ": must be a mapping with name and type");
    }
    ScanFilterSpec spec;
    spec.name = scalarText(entry["name"], at + "/name");
    spec.type = scalarText(entry["type"], at + "/type");
    if (entry.hasMember("params")) {
      XmlRpc::XmlRpcValue& params = entry["params"];
      if (params.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
        throw ParameterError("parameter " + at + "/params: must be a mapping");
      }
      for (auto& kv : params) spec.params[kv.first] = scalarText(kv.second, at + "/" + kv.first);
    }
    for (auto& kv : entry) {
      if (kv.first != "name" && kv.first != "type" && kv.first != "params") {
        throw ParameterError("parameter " + at + "/" + kv.first +
                             ": unknown key (an entry has name, type, params)");
      }
    }
    out.push_back(std::move(spec));
  }
  return out;
}

}  // namespace ekf_slam
