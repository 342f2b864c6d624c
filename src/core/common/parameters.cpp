// String-backed parameter source and the validating reader every algorithm's configure() uses.
#include "ekf_slam/core/common/parameters.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace ekf_slam {
namespace {

std::string trim(const std::string& s) {
  const auto first =
      std::find_if_not(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c); });
  const auto last = std::find_if_not(s.rbegin(), s.rend(), [](unsigned char c) {
                      return std::isspace(c);
                    }).base();
  return first < last ? std::string(first, last) : std::string();
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

[[noreturn]] void wrongType(const std::string& name, const std::string& text,
                            const char* expected) {
  throw std::invalid_argument("parameter " + name + ": '" + text + "' is not " + expected);
}

template <typename T>
std::string str(const T& v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// A source's type error becomes a ParameterError (one type for callers to catch) that names the
// parameter, whether or not the source's own message did.
[[noreturn]] void rethrowNamed(const ParameterSource& source, const std::string& name,
                               const std::invalid_argument& e) {
  const std::string what = e.what();
  const std::string full = source.qualify(name);
  if (what.find(full) != std::string::npos) throw ParameterError(what);
  throw ParameterError("parameter " + full + ": " + what);
}

}  // namespace

void requireParameter(bool ok, const std::string& name, const std::string& what, double value) {
  if (ok) return;
  std::ostringstream os;
  os << "parameter " << name << ": " << what << ", got " << value;
  throw ParameterError(os.str());
}

// --- MapParameterSource --------------------------------------------------------------------------

bool MapParameterSource::get(const std::string& name, double* value) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return false;
  const std::string text = trim(it->second);
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  // Whole string consumed; ERANGE only for overflow (underflow to ~0 is a valid reading).
  if (text.empty() || *end != '\0' || (errno == ERANGE && std::isinf(v))) {
    wrongType(qualify(name), it->second, "a number");
  }
  *value = v;
  return true;
}

bool MapParameterSource::get(const std::string& name, int* value) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return false;
  const std::string text = trim(it->second);
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(begin, &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < INT_MIN || v > INT_MAX) {
    wrongType(qualify(name), it->second, "an integer");
  }
  *value = static_cast<int>(v);
  return true;
}

bool MapParameterSource::get(const std::string& name, bool* value) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return false;
  // The YAML 1.1 spellings, as rosparam accepts them.
  const std::string text = lower(trim(it->second));
  if (text == "true" || text == "yes" || text == "on" || text == "1") {
    *value = true;
  } else if (text == "false" || text == "no" || text == "off" || text == "0") {
    *value = false;
  } else {
    wrongType(qualify(name), it->second, "a boolean");
  }
  return true;
}

bool MapParameterSource::get(const std::string& name, std::string* value) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return false;
  *value = it->second;
  return true;
}

// --- ParameterReader -----------------------------------------------------------------------------

void ParameterReader::fail(const std::string& name, const std::string& what) const {
  throw ParameterError("parameter " + source_.qualify(name) + ": " + what);
}

double ParameterReader::number(const std::string& name, double default_value) const {
  double v = default_value;
  try {
    source_.get(name, &v);
  } catch (const std::invalid_argument& e) {
    rethrowNamed(source_, name, e);
  }
  if (!std::isfinite(v)) fail(name, "must be finite, got " + str(v));
  return v;
}

double ParameterReader::positive(const std::string& name, double default_value) const {
  const double v = number(name, default_value);
  if (!(v > 0.0)) fail(name, "must be > 0, got " + str(v));
  return v;
}

double ParameterReader::nonNegative(const std::string& name, double default_value) const {
  const double v = number(name, default_value);
  if (!(v >= 0.0)) fail(name, "must be >= 0, got " + str(v));
  return v;
}

double ParameterReader::inRange(const std::string& name, double default_value, double lo,
                                double hi) const {
  const double v = number(name, default_value);
  if (!(v >= lo && v <= hi)) {
    fail(name, "must lie in [" + str(lo) + ", " + str(hi) + "], got " + str(v));
  }
  return v;
}

double ParameterReader::probability(const std::string& name, double default_value) const {
  const double v = number(name, default_value);
  if (!(v > 0.0 && v < 1.0)) fail(name, "must be a probability in (0, 1), got " + str(v));
  return v;
}

int ParameterReader::integer(const std::string& name, int default_value, int lo, int hi) const {
  int v = default_value;
  try {
    source_.get(name, &v);
  } catch (const std::invalid_argument& e) {
    rethrowNamed(source_, name, e);
  }
  if (v < lo || v > hi) {
    fail(name, "must lie in [" + str(lo) + ", " + str(hi) + "], got " + str(v));
  }
  return v;
}

bool ParameterReader::flag(const std::string& name, bool default_value) const {
  bool v = default_value;
  try {
    source_.get(name, &v);
  } catch (const std::invalid_argument& e) {
    rethrowNamed(source_, name, e);
  }
  return v;
}

std::string ParameterReader::text(const std::string& name, const std::string& default_value,
                                  const std::vector<std::string>& allowed) const {
  std::string v = default_value;
  try {
    source_.get(name, &v);
  } catch (const std::invalid_argument& e) {
    rethrowNamed(source_, name, e);
  }
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    fail(name, "must be one of {" + list + "}, got '" + v + "'");
  }
  return v;
}

}  // namespace ekf_slam
