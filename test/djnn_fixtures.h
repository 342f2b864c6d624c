// DJNN configured with the paper's settings, shared by the DJNN tests.
#pragma once

#include <map>
#include <string>

#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {
namespace assoc_test {

// The paper's settings (0.95 gates, admission when seen twice, no static / bias tests, no density
// estimate or joint decision at loop closures, the paper's greedy resolution of interference, P_D 1
// stated so that it is not estimated): the
// hand-made problems of the tests are worked out for them. `params` override them; an empty value
// leaves the key unset.
inline DJNN makeDjnn(const std::map<std::string, std::string>& params = {}) {
  std::map<std::string, std::string> p = {{"individual_probability", "0.95"},
                                          {"ambiguity_probability", "0.95"},
                                          {"admit_evidence", "2"},
                                          {"static_test", "false"},
                                          {"bias_test", "false"},
                                          {"estimate_landmark_density", "false"},
                                          {"loop_closure_age", "0"},
                                          {"optimal_assignment", "false"},
                                          {"detection_probability", "1"}};
  for (const auto& kv : params) {
    if (kv.second.empty()) {
      p.erase(kv.first);
    } else {
      p[kv.first] = kv.second;
    }
  }
  DJNN d;
  d.configure(MapParameterSource(p));
  return d;
}

}  // namespace assoc_test
}  // namespace ekf_slam
