#include "ekf_slam/core/common/recording_parameter_source.h"

#include <algorithm>

namespace ekf_slam {

std::string nearestName(const std::string& name, const std::vector<std::string>& candidates) {
  // Levenshtein distance, one row at a time.
  const auto distance = [](const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1,
                           diagonal + static_cast<std::size_t>(a[i - 1] != b[j - 1])});
        diagonal = up;
      }
    }
    return row[b.size()];
  };
  std::string best;
  std::size_t best_distance = (name.size() + 2) / 3 + 1;  // only strictly closer ones count
  for (const std::string& c : candidates) {
    const std::size_t d = distance(name, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::vector<std::string> RecordingParameterSource::unread(
    const std::vector<std::string>& also_known) const {
  std::vector<std::string> out;
  for (const std::string& n : names_) {
    if (read_.count(n) == 0 &&
        std::find(also_known.begin(), also_known.end(), n) == also_known.end()) {
      out.push_back(n);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

void RecordingParameterSource::rejectUnread(const std::vector<std::string>& also_known) const {
  const std::vector<std::string> unknown = unread(also_known);
  if (unknown.empty()) return;
  std::vector<std::string> known(read_.begin(), read_.end());
  known.insert(known.end(), also_known.begin(), also_known.end());
  std::string message;
  for (const std::string& n : unknown) {
    const std::string near = nearestName(n, known);
    message += (message.empty() ? "" : "; ") + std::string("unknown parameter ") +
               inner_.qualify(n) + (near.empty() ? "" : " (did you mean " + near + "?)");
  }
  throw ParameterError(message);
}

}  // namespace ekf_slam
