// DJNN extension "missed-detection profile" (docs/djnn.md): the defaults DJNN uses when the
// sensor's stated detection_probability is below 1 (a camera, a sensor that misses landmarks).
// Such a sensor leaves many features tentative for long while the pose is corrected, lets movers
// pass close to landmarks between sightings, and returns to old places with the pose uncertain by
// more than the landmark spacing. The extensions written for those failures (follow pose, static
// heading, the shift and density tests, established landmarks, remembered sightings and held
// confirmations at the loop closures) are then on by default. A value the user sets always wins;
// `missed_detection_profile: false` turns the profile off; a sensor with P_D = 1 (the papers',
// Victoria Park) reads exactly the documented defaults. (The online density estimate and the
// joint decision at loop closures were in the profile until 6 Dec 2026; they are defaults now.)
#pragma once

#include <map>
#include <string>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// The profile's defaults (parameter name -> value), applied below the user's parameters.
const std::map<std::string, std::string>& missedDetectionDefaults();

/// The user's parameters over `defaults`: a parameter the user set is read from `user`, any other
/// named in `defaults` from there. Reads of the user's source are recorded by it as usual (unread
/// keys stay an error).
class ParameterDefaults : public ParameterSource {
 public:
  ParameterDefaults(const ParameterSource& user, const std::map<std::string, std::string>& defaults)
      : user_(user), defaults_(defaults) {}
  bool get(const std::string& name, double* value) const override { return read(name, value); }
  bool get(const std::string& name, int* value) const override { return read(name, value); }
  bool get(const std::string& name, bool* value) const override { return read(name, value); }
  bool get(const std::string& name, std::string* value) const override { return read(name, value); }
  std::string qualify(const std::string& name) const override { return user_.qualify(name); }

 private:
  template <typename T>
  bool read(const std::string& name, T* value) const {
    return user_.get(name, value) || defaults_.get(name, value);
  }
  const ParameterSource& user_;
  MapParameterSource defaults_;
};

}  // namespace ekf_slam
