// Temporary folders and file reading shared by the tests.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdlib>
#include <cstring>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace test_files {

/// A fresh folder under the system's temporary directory, removed with everything in it when the
/// object goes away.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "ekf_slam_test") {
    std::string templ = (std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string();
    if (mkdtemp(templ.data()) == nullptr) throw std::runtime_error("mkdtemp failed: " + templ);
    path_ = templ;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

/// The whole file ("" when it cannot be read).
inline std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// (x, y) of every row of the offline runner's landmarks.csv (id,x,y,...), header skipped.
inline std::vector<std::pair<double, double>> landmarkPositions(const std::string& path) {
  std::ifstream csv(path);
  std::string line;
  std::getline(csv, line);
  std::vector<std::pair<double, double>> out;
  while (std::getline(csv, line)) {
    std::istringstream row(line);
    std::string id, x, y;
    std::getline(row, id, ',');
    std::getline(row, x, ',');
    std::getline(row, y, ',');
    out.emplace_back(std::strtod(x.c_str(), nullptr), std::strtod(y.c_str(), nullptr));
  }
  return out;
}

/// True in CI (CI=true), where every input a test needs must be there.
inline bool inCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::strcmp(ci, "true") == 0;
}

}  // namespace test_files

/// Data a test needs (the Victoria Park set) is missing: a skip on a user's machine, counted in
/// the summary line of scripts/test.sh, but a failure in CI (CI=true), where a skip would pass
/// without testing anything.
#define EKF_SLAM_SKIP_WITHOUT_DATA(message)                      \
  do {                                                           \
    if (test_files::inCi()) {                                    \
      FAIL() << message << " (CI=true: the data must be there)"; \
    } else {                                                     \
      GTEST_SKIP() << message;                                   \
    }                                                            \
  } while (0)
