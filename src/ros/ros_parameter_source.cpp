#include "ekf_slam/ros/ros_parameter_source.h"

#include <xmlrpcpp/XmlRpcValue.h>

namespace ekf_slam {

namespace {

const char* typeName(XmlRpc::XmlRpcValue::Type t) {
  switch (t) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpc::XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpc::XmlRpcValue::TypeDouble:
      return "a double";
    case XmlRpc::XmlRpcValue::TypeString:
      return "a string";
    case XmlRpc::XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "a dictionary";
    default:
      return "an unsupported value";
  }
}

// Fetches the raw value so that a type mismatch is reported instead of read as "not set"
// (NodeHandle::getParam(name, double&) returns false for a string).
bool fetch(const ros::NodeHandle& nh, const std::string& name, XmlRpc::XmlRpcValue* v) {
  return nh.getParam(name, *v);
}

[[noreturn]] void wrongType(const RosParameterSource& src, const std::string& name,
                            const char* expected, const XmlRpc::XmlRpcValue& v) {
  throw ParameterError("parameter " + src.qualify(name) + ": expected " + expected + ", got " +
                       typeName(v.getType()));
}

}  // namespace

bool RosParameterSource::get(const std::string& name, double* value) const {
  XmlRpc::XmlRpcValue v;
  if (!fetch(nh_, name, &v)) return false;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    *value = static_cast<double>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    *value = static_cast<int>(v);
  } else {
    wrongType(*this, name, "a number", v);
  }
  return true;
}

bool RosParameterSource::get(const std::string& name, int* value) const {
  XmlRpc::XmlRpcValue v;
  if (!fetch(nh_, name, &v)) return false;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeInt) wrongType(*this, name, "an integer", v);
  *value = static_cast<int>(v);
  return true;
}

bool RosParameterSource::get(const std::string& name, bool* value) const {
  XmlRpc::XmlRpcValue v;
  if (!fetch(nh_, name, &v)) return false;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) wrongType(*this, name, "a boolean", v);
  *value = static_cast<bool>(v);
  return true;
}

bool RosParameterSource::get(const std::string& name, std::string* value) const {
  XmlRpc::XmlRpcValue v;
  if (!fetch(nh_, name, &v)) return false;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString) wrongType(*this, name, "a string", v);
  *value = static_cast<std::string>(v);
  return true;
}

std::vector<std::string> RosParameterSource::names() const {
  std::vector<std::string> all, out;
  if (!nh_.getParamNames(all)) return out;
  const std::string prefix = nh_.getNamespace() + "/";
  for (const std::string& n : all) {
    if (n.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = n.substr(prefix.size());
    if (!rest.empty() && rest.find('/') == std::string::npos) out.push_back(rest);
  }
  return out;
}

}  // namespace ekf_slam
