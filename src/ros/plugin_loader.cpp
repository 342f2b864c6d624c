#include "ekf_slam/ros/plugin_loader.h"

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

template <class Base>
PluginLoader<Base>::PluginLoader() {
  try {
    loader_ =
        std::make_shared<pluginlib::ClassLoader<Base>>("ekf_slam", PluginFamily<Base>::kBaseClass);
  } catch (const pluginlib::PluginlibException& e) {
    throw std::runtime_error(std::string("cannot read the ") + PluginFamily<Base>::kNoun +
                             " plugins of package ekf_slam (is the package on ROS_PACKAGE_PATH, "
                             "i.e. devel/setup.bash sourced?): " +
                             e.what());
  }
}

template <class Base>
PluginLoader<Base>::~PluginLoader() = default;

template <class Base>
std::vector<std::string> PluginLoader<Base>::available() const {
  auto names = loader_->getDeclaredClasses();
  std::sort(names.begin(), names.end());
  return names;
}

template <class Base>
std::string PluginLoader<Base>::lookupName(const std::string& name) {
  return pluginLookupName(name);
}

template <class Base>
std::shared_ptr<Base> PluginLoader<Base>::create(const std::string& name,
                                                 const ParameterSource& params) const {
  std::shared_ptr<Base> result = instantiate(name);
  result->configure(params);
  return result;
}

template <class Base>
std::shared_ptr<Base> PluginLoader<Base>::instantiate(const std::string& name) const {
  const std::string lookup = lookupName(name);
  const std::string noun = PluginFamily<Base>::kNoun;
  if (!loader_->isClassAvailable(lookup)) {
    throw UnknownPluginError("unknown " + noun + " '" + name +
                             "'; available: " + join(available()));
  }
  std::shared_ptr<Base> instance;
  try {
    instance = loader_->createSharedInstance(lookup);
  } catch (const pluginlib::PluginlibException& e) {
    throw std::runtime_error("cannot create " + noun + " '" + lookup + "': " + e.what());
  }
  // The returned pointer owns both the instance and a reference to the loader: the instance is
  // destroyed first, then (maybe) the loader, which unloads the library.
  auto loader = loader_;
  Base* raw = instance.get();
  std::shared_ptr<Base> result(
      raw, [instance = std::move(instance), loader = std::move(loader)](Base*) mutable {
        instance.reset();
        loader.reset();
      });
  return result;
}

// The families of the package.
template class PluginLoader<DataAssociation>;
template class PluginLoader<Relocaliser>;
template class PluginLoader<FeatureExtractor>;

}  // namespace ekf_slam
