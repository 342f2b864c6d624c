// The map file of ~save_map / ~load_map and --load-map.
#include "ekf_slam/core/pipeline/map_file.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

namespace ekf_slam {

namespace {

constexpr const char* kMapHeader = "ekf_slam_map 1";

}  // namespace

void writeMapFile(const std::string& path, const std::vector<MapLandmark>& map,
                  const LandmarkBook& book) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("map file '" + path + "': cannot open for writing");
  out << kMapHeader << "\n"
      << "# " << map.size() << " landmarks; map frame, metres\n"
      << "# id x y cov_xx cov_xy cov_yy diameter times_observed\n";
  char line[512];
  for (const MapLandmark& l : map) {
    const Eigen::Vector2d& m = l.position;
    const Eigen::Matrix2d& C = l.covariance;
    const LandmarkInfo& info = book.info(l.id);
    // %.17g: doubles round-trip exactly.
    std::snprintf(line, sizeof(line), "%lld %.17g %.17g %.17g %.17g %.17g %.17g %u\n",
                  static_cast<long long>(l.id), m.x(), m.y(), C(0, 0), C(0, 1), C(1, 1),
                  info.diameter, info.times_observed);
    out << line;
  }
  out.flush();
  if (!out) throw std::runtime_error("map file '" + path + "': write failed");
}

namespace {

bool parseDouble(const std::string& token, double* v) {
  char* end = nullptr;
  *v = std::strtod(token.c_str(), &end);
  return !token.empty() && *end == '\0';
}

bool parseInteger(const std::string& token, long long* v) {
  char* end = nullptr;
  errno = 0;
  *v = std::strtoll(token.c_str(), &end, 10);
  return !token.empty() && *end == '\0' && errno == 0;
}

}  // namespace

std::vector<MapEntry> readMapFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("map file '" + path + "': cannot open");
  const auto fail = [&path](int line, const std::string& what) {
    throw std::runtime_error("map file '" + path + "' line " + std::to_string(line) + ": " + what);
  };
  std::vector<MapEntry> entries;
  std::map<LandmarkId, int> line_of;
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (line == 1) {
      if (text != kMapHeader)
        fail(1, "expected the header '" + std::string(kMapHeader) + "', got '" + text + "'");
      continue;
    }
    std::istringstream fields(text);
    std::vector<std::string> tok;
    for (std::string t; fields >> t;) tok.push_back(t);
    if (tok.empty() || tok[0][0] == '#') continue;
    if (tok.size() != 8) {
      fail(line, "expected 8 fields (id x y cov_xx cov_xy cov_yy diameter times_observed), got " +
                     std::to_string(tok.size()));
    }
    MapEntry e;
    long long id = 0, times = 0;
    if (!parseInteger(tok[0], &id) || id < 0) fail(line, "bad id '" + tok[0] + "'");
    e.id = id;
    double v[6];
    const char* names[6] = {"x", "y", "cov_xx", "cov_xy", "cov_yy", "diameter"};
    for (int k = 0; k < 6; ++k) {
      if (!parseDouble(tok[1 + k], &v[k]) || (k < 5 && !std::isfinite(v[k])))
        fail(line, std::string("bad ") + names[k] + " '" + tok[1 + k] + "'");
    }
    if (!parseInteger(tok[7], &times) || times < 0 || times > 0xffffffffLL)
      fail(line, "bad times_observed '" + tok[7] + "'");
    e.position = Eigen::Vector2d(v[0], v[1]);
    e.cov << v[2], v[3], v[3], v[4];
    if (!(v[2] > 0.0 && v[4] > 0.0 && v[2] * v[4] - v[3] * v[3] > 0.0))
      fail(line, "covariance is not positive definite");
    if (std::isinf(v[5]) || v[5] < 0.0) fail(line, "bad diameter '" + tok[6] + "'");
    e.info.diameter = v[5];
    e.info.descriptor_count = std::isnan(v[5]) ? 0 : 1;
    e.info.times_observed = static_cast<std::uint32_t>(times);
    const auto seen = line_of.emplace(e.id, line);
    if (!seen.second) {
      fail(line, "duplicate id " + std::to_string(e.id) + " (first on line " +
                     std::to_string(seen.first->second) + ")");
    }
    entries.push_back(e);
  }
  if (line == 0) fail(1, "empty file (expected the header '" + std::string(kMapHeader) + "')");
  return entries;
}

}  // namespace ekf_slam
