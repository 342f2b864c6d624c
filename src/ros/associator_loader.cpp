#include "ekf_slam/ros/associator_loader.h"

#include <algorithm>

#include <pluginlib/class_loader.hpp>

namespace ekf_slam {

namespace {

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

AssociatorLoader::AssociatorLoader() {
  try {
    loader_ = std::make_shared<pluginlib::ClassLoader<DataAssociation>>(
        "ekf_slam", "ekf_slam::DataAssociation");
  } catch (const pluginlib::PluginlibException& e) {
    throw std::runtime_error(
        std::string("cannot read the associator plugins of package ekf_slam (is the package on "
                    "ROS_PACKAGE_PATH, i.e. devel/setup.bash sourced?): ") +
        e.what());
  }
}

AssociatorLoader::~AssociatorLoader() = default;

std::vector<std::string> AssociatorLoader::available() const {
  auto names = loader_->getDeclaredClasses();
  std::sort(names.begin(), names.end());
  return names;
}

std::string AssociatorLoader::lookupName(const std::string& name) {
  return name.find('/') == std::string::npos ? "ekf_slam/" + name : name;
}

std::shared_ptr<DataAssociation> AssociatorLoader::create(const std::string& name,
                                                          const ParameterSource& params) const {
  const std::string lookup = lookupName(name);
  if (!loader_->isClassAvailable(lookup)) {
    throw UnknownAssociatorError("unknown associator '" + name +
                                 "'; available: " + join(available()));
  }
  std::shared_ptr<DataAssociation> instance;
  try {
    instance = loader_->createSharedInstance(lookup);
  } catch (const pluginlib::PluginlibException& e) {
    throw std::runtime_error("cannot create associator '" + lookup + "': " + e.what());
  }
  // The returned pointer owns both the instance and a reference to the loader: the instance is
  // destroyed first, then (maybe) the loader, which unloads the library.
  auto loader = loader_;
  DataAssociation* raw = instance.get();
  std::shared_ptr<DataAssociation> result(
      raw, [instance = std::move(instance), loader = std::move(loader)](DataAssociation*) mutable {
        instance.reset();
        loader.reset();
      });
  result->configure(params);
  return result;
}

}  // namespace ekf_slam
