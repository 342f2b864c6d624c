// Victoria Park reader: libmatio for the MAT files, a hand-rolled number scanner for the ASCII
// laser file (15 MB without line breaks; iostreams take seconds, from_chars a fraction of that).
#include "ekf_slam/data/victoria_park.h"

#include <matio.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace ekf_slam {
namespace victoria_park {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& file, const std::string& what) {
  throw std::runtime_error(file + ": " + what);
}

std::string joinPath(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name).string();
}

void requireFile(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "file not found");
  if (!fs::is_regular_file(path, ec)) fail(path, "not a regular file");
}

std::string readWholeFile(const std::string& path) {
  requireFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  std::string buffer(static_cast<std::size_t>(size), '\0');
  if (size > 0 && !in.read(buffer.data(), size)) fail(path, "read error");
  return buffer;
}

// Calls fn(value, token_begin) for every whitespace-separated number in buffer. Throws naming the
// file, the byte offset and the offending token on anything that is not a number.
template <typename Fn>
void scanNumbers(const std::string& path, const std::string& buffer, Fn&& fn) {
  const char* p = buffer.data();
  const char* const end = p + buffer.size();
  auto is_space = [](char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
  };
  while (true) {
    while (p < end && is_space(*p)) ++p;
    if (p == end) break;
    double value = 0.0;
    const char* start = p;
    if (*start == '+')
      ++start;  // from_chars rejects a leading '+', strtod-written files may have it
    const auto [next, ec] = std::from_chars(start, end, value);
    if (ec != std::errc() || (next < end && !is_space(*next)) || !std::isfinite(value)) {
      const char* token_end = p;
      while (token_end < end && !is_space(*token_end) && token_end - p < 32) ++token_end;
      std::ostringstream msg;
      msg << "non-numeric token '" << std::string(p, token_end) << "' at byte "
          << (p - buffer.data());
      fail(path, msg.str());
    }
    fn(value);
    p = next;
  }
}

// RAII for the matio handles.
struct MatCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct VarFreer {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatPtr = std::unique_ptr<mat_t, MatCloser>;
using VarPtr = std::unique_ptr<matvar_t, VarFreer>;

MatPtr openMat(const std::string& path) {
  requireFile(path);
  MatPtr mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) fail(path, "not a readable MATLAB MAT file");
  return mat;
}

template <typename T>
void appendAs(const void* data, std::size_t n, std::vector<double>* out) {
  const T* v = static_cast<const T*>(data);
  for (std::size_t i = 0; i < n; ++i) out->push_back(static_cast<double>(v[i]));
}

// Any real numeric vector (N x 1 or 1 x N) as doubles.
std::vector<double> readVector(mat_t* mat, const std::string& path, const char* name) {
  VarPtr var(Mat_VarRead(mat, name));
  const std::string where = std::string("variable '") + name + "'";
  if (!var) fail(path, "missing " + where);
  if (var->isComplex || var->rank != 2 || var->data == nullptr) {
    fail(path, where + " is not a real numeric vector");
  }
  if (var->dims[0] != 1 && var->dims[1] != 1) {
    fail(path, where + " is a " + std::to_string(var->dims[0]) + " x " +
                   std::to_string(var->dims[1]) + " matrix, expected a vector");
  }
  const std::size_t n = var->dims[0] * var->dims[1];
  std::vector<double> out;
  out.reserve(n);
  switch (var->class_type) {
    case MAT_C_DOUBLE:
      appendAs<double>(var->data, n, &out);
      break;
    case MAT_C_SINGLE:
      appendAs<float>(var->data, n, &out);
      break;
    case MAT_C_INT8:
      appendAs<std::int8_t>(var->data, n, &out);
      break;
    case MAT_C_UINT8:
      appendAs<std::uint8_t>(var->data, n, &out);
      break;
    case MAT_C_INT16:
      appendAs<std::int16_t>(var->data, n, &out);
      break;
    case MAT_C_UINT16:
      appendAs<std::uint16_t>(var->data, n, &out);
      break;
    case MAT_C_INT32:
      appendAs<std::int32_t>(var->data, n, &out);
      break;
    case MAT_C_UINT32:
      appendAs<std::uint32_t>(var->data, n, &out);
      break;
    case MAT_C_INT64:
      appendAs<std::int64_t>(var->data, n, &out);
      break;
    case MAT_C_UINT64:
      appendAs<std::uint64_t>(var->data, n, &out);
      break;
    default:
      fail(path, where + " is not numeric");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(out[i]))
      fail(path, where + " has a non-finite value at " + std::to_string(i));
  }
  if (out.empty()) fail(path, where + " is empty");
  return out;
}

// Millisecond stamps: integral and strictly increasing (the streams are merged by time).
std::vector<std::int64_t> toTimes(const std::vector<double>& t, const std::string& path,
                                  const char* name) {
  std::vector<std::int64_t> out(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    out[i] = std::llround(t[i]);
    if (std::abs(t[i] - static_cast<double>(out[i])) > 1e-6) {
      fail(path, std::string("'") + name + "' is not in whole milliseconds at index " +
                     std::to_string(i));
    }
    if (i > 0 && out[i] <= out[i - 1]) {
      fail(path, std::string("'") + name + "' is not increasing at index " + std::to_string(i));
    }
  }
  return out;
}

void requireSameLength(const std::string& path, const char* a, std::size_t na, const char* b,
                       std::size_t nb) {
  if (na != nb) {
    fail(path, std::string("wrong length: '") + b + "' has " + std::to_string(nb) +
                   " values but '" + a + "' has " + std::to_string(na));
  }
}

}  // namespace

std::string defaultDataDir() {
  const char* env = std::getenv("VP_DATA");
  const fs::path dir = (env != nullptr && *env != '\0') ? fs::path(env)
                                                        : fs::path(EKF_SLAM_SOURCE_DIR) / ".." /
                                                              "shared" / "data" / "victoria_park";
  std::string s = dir.lexically_normal().string();
  while (s.size() > 1 && s.back() == '/') s.pop_back();
  return s;
}

DeadReckoning loadDeadReckoning(const std::string& data_dir) {
  const std::string path = joinPath(data_dir, "aa3_dr.mat");
  MatPtr mat = openMat(path);
  const std::vector<double> time = readVector(mat.get(), path, "time");
  DeadReckoning dr;
  dr.speed = readVector(mat.get(), path, "speed");
  dr.steering = readVector(mat.get(), path, "steering");
  requireSameLength(path, "time", time.size(), "speed", dr.speed.size());
  requireSameLength(path, "time", time.size(), "steering", dr.steering.size());
  dr.time_ms = toTimes(time, path, "time");
  return dr;
}

Gps loadGps(const std::string& data_dir) {
  const std::string path = joinPath(data_dir, "aa3_gpsx.mat");
  MatPtr mat = openMat(path);
  const std::vector<double> time = readVector(mat.get(), path, "timeGps");
  Gps gps;
  gps.x = readVector(mat.get(), path, "Lo_m");
  gps.y = readVector(mat.get(), path, "La_m");
  requireSameLength(path, "timeGps", time.size(), "Lo_m", gps.x.size());
  requireSameLength(path, "timeGps", time.size(), "La_m", gps.y.size());
  gps.time_ms = toTimes(time, path, "timeGps");
  return gps;
}

std::vector<std::int64_t> loadLaserSampling(const std::string& data_dir) {
  const std::string path = joinPath(data_dir, "lasersampling.txt");
  const std::string buffer = readWholeFile(path);
  std::vector<double> t;
  scanNumbers(path, buffer, [&](double v) { t.push_back(v); });
  if (t.empty()) fail(path, "no time stamps");
  return toTimes(t, path, "time");
}

LaserScans loadLaser(const std::string& data_dir) {
  const std::string path = joinPath(data_dir, "victoria_park_ascii/LASER.txt");
  const std::string buffer = readWholeFile(path);
  constexpr std::size_t kGroup = kBeams + 1;

  LaserScans scans;
  // About 5.9 bytes per value in this file; reserving avoids regrowth of 7000 vectors.
  const std::size_t expected_scans = buffer.size() / (kGroup * 5) + 1;
  scans.time_ms.reserve(expected_scans);
  scans.ranges.reserve(expected_scans);
  std::size_t count = 0;
  scanNumbers(path, buffer, [&](double v) {
    const std::size_t k = count++ % kGroup;
    if (k == 0) {
      scans.time_ms.push_back(std::llround(v * 1000.0) + kAsciiEpochMs);
      scans.ranges.emplace_back();
      scans.ranges.back().reserve(kBeams);
    } else {
      if (v < 0.0) {
        fail(path, "negative range " + std::to_string(v) + " in scan " +
                       std::to_string(scans.ranges.size() - 1));
      }
      scans.ranges.back().push_back(static_cast<float>(v));
    }
  });
  if (count == 0) fail(path, "no numbers");
  if (count % kGroup != 0) {
    fail(path, "value count " + std::to_string(count) + " is not a multiple of " +
                   std::to_string(kGroup) + " (time + " + std::to_string(kBeams) +
                   " ranges per scan)");
  }
  for (std::size_t i = 1; i < scans.time_ms.size(); ++i) {
    if (scans.time_ms[i] <= scans.time_ms[i - 1]) {
      fail(path, "scan times are not increasing at scan " + std::to_string(i));
    }
  }

  // The ASCII times must be the original TLsr stamps; a mismatch means a wrong or edited file.
  const std::string sampling = joinPath(data_dir, "lasersampling.txt");
  std::error_code ec;
  if (fs::exists(sampling, ec)) {
    const std::vector<std::int64_t> tlsr = loadLaserSampling(data_dir);
    if (tlsr.size() < scans.time_ms.size()) {
      fail(path, "has " + std::to_string(scans.time_ms.size()) + " scans but " + sampling +
                     " only " + std::to_string(tlsr.size()) + " stamps");
    }
    for (std::size_t i = 0; i < scans.time_ms.size(); ++i) {
      if (tlsr[i] != scans.time_ms[i]) {
        fail(path, "scan " + std::to_string(i) + " at " + std::to_string(scans.time_ms[i]) +
                       " ms disagrees with " + sampling + " (" + std::to_string(tlsr[i]) + " ms)");
      }
    }
  }
  return scans;
}

}  // namespace victoria_park
}  // namespace ekf_slam
