// Every associator of the package by its short name, constructed directly (no pluginlib), for
// tests that replay association problems.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/jcbb.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/association/rrwsc.h"

namespace ekf_slam {

/// Null for an unknown name.
inline std::unique_ptr<DataAssociation> makeAssociator(const std::string& name) {
  if (name == "NN") return std::make_unique<NN>();
  if (name == "JCBB") return std::make_unique<JCBB>();
  if (name == "DJNN") return std::make_unique<DJNN>();
  if (name == "NNJCBB") return std::make_unique<NNJCBB>();
  if (name == "Hungarian") return std::make_unique<Hungarian>();
  if (name == "RRWSC") return std::make_unique<RRWSC>();
  return nullptr;
}

}  // namespace ekf_slam
