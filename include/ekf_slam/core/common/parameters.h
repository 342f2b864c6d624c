// Where an algorithm gets its parameters from, without knowing about ROS. The ROS side implements
// ParameterSource over a NodeHandle; tests and tools use MapParameterSource (e.g. filled from
// YAML). Every algorithm reads all of its parameters in one configure() call with
// ParameterReader, which applies the documented default and validates the value.
#pragma once

#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace ekf_slam {

class ParameterSource {
 public:
  virtual ~ParameterSource() = default;
  /// Each returns false when the parameter is not set; throws std::invalid_argument when it is
  /// set but has the wrong type.
  virtual bool get(const std::string& name, double* value) const = 0;
  virtual bool get(const std::string& name, int* value) const = 0;
  virtual bool get(const std::string& name, bool* value) const = 0;
  virtual bool get(const std::string& name, std::string* value) const = 0;
  /// Full name of a parameter, for error messages (e.g. "/ekf_slam/DJNN/gate").
  virtual std::string qualify(const std::string& name) const { return name; }
};

/// Parameters held as strings (from YAML, the command line or a test), converted on read.
class MapParameterSource : public ParameterSource {
 public:
  MapParameterSource() = default;
  explicit MapParameterSource(std::map<std::string, std::string> values, std::string prefix = "")
      : values_(std::move(values)), prefix_(std::move(prefix)) {}
  void set(const std::string& name, const std::string& value) { values_[name] = value; }

  bool get(const std::string& name, double* value) const override;
  bool get(const std::string& name, int* value) const override;
  bool get(const std::string& name, bool* value) const override;
  bool get(const std::string& name, std::string* value) const override;
  std::string qualify(const std::string& name) const override { return prefix_ + name; }

 private:
  std::map<std::string, std::string> values_;
  std::string prefix_;
};

/// Thrown for a parameter with an invalid value; the message names the parameter.
class ParameterError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Cross-field checks after reading: throws ParameterError "parameter NAME: WHAT, got VALUE"
/// unless `ok`.
void requireParameter(bool ok, const std::string& name, const std::string& what, double value);

/// Reads parameters with defaults and range checks, so each algorithm's configure() is a list of
/// one-liners:  gate_ = reader.positive("gate", 5.99);
class ParameterReader {
 public:
  explicit ParameterReader(const ParameterSource& source) : source_(source) {}

  double number(const std::string& name, double default_value) const;
  /// value > 0
  double positive(const std::string& name, double default_value) const;
  /// value >= 0
  double nonNegative(const std::string& name, double default_value) const;
  /// lo <= value <= hi
  double inRange(const std::string& name, double default_value, double lo, double hi) const;
  /// Probability strictly inside (0, 1).
  double probability(const std::string& name, double default_value) const;
  int integer(const std::string& name, int default_value, int lo, int hi) const;
  bool flag(const std::string& name, bool default_value) const;
  std::string text(const std::string& name, const std::string& default_value,
                   const std::vector<std::string>& allowed = {}) const;

  [[noreturn]] void fail(const std::string& name, const std::string& what) const;

 private:
  const ParameterSource& source_;
};

}  // namespace ekf_slam
