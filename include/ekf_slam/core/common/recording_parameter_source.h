// Unknown parameter names: a misspelt name (`sigma_rnage`) must be an error, not a default used
// in silence. RecordingParameterSource passes reads through to another source and remembers
// every name asked for; after everything was read, rejectUnread() names what nobody read.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class RecordingParameterSource : public ParameterSource {
 public:
  /// `names`: the parameters the inner source holds (e.g. YamlParameterSource::names()).
  RecordingParameterSource(const ParameterSource& inner, std::vector<std::string> names)
      : inner_(inner), names_(std::move(names)) {}

  bool get(const std::string& name, double* value) const override { return pass(name, value); }
  bool get(const std::string& name, int* value) const override { return pass(name, value); }
  bool get(const std::string& name, bool* value) const override { return pass(name, value); }
  bool get(const std::string& name, std::string* value) const override { return pass(name, value); }
  std::string qualify(const std::string& name) const override { return inner_.qualify(name); }

  /// Names held but never read (nor listed in `also_known`), sorted.
  std::vector<std::string> unread(const std::vector<std::string>& also_known = {}) const;
  /// Throws ParameterError naming every unread parameter and, for each, the nearest name that
  /// was read or is known ("did you mean ...?").
  void rejectUnread(const std::vector<std::string>& also_known = {}) const;

 private:
  template <typename T>
  bool pass(const std::string& name, T* value) const {
    read_.insert(name);
    return inner_.get(name, value);
  }
  const ParameterSource& inner_;
  std::vector<std::string> names_;
  mutable std::set<std::string> read_;
};

/// The candidate closest to `name` by edit distance, or "" when none is close (at most a third
/// of the name's length, rounded up).
std::string nearestName(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace ekf_slam
