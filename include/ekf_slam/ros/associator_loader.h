// AssociatorLoader is PluginLoader<DataAssociation>: see plugin_loader.h. Kept for the node,
// which includes this name.
#pragma once

#include "ekf_slam/ros/plugin_loader.h"
