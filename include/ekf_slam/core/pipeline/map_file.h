// The map file (~save_map, ~load_map, --load-map, map.txt): plain text, a header line
// "ekf_slam_map 1", '#' comment lines, then one landmark per line
//   id x y cov_xx cov_xy cov_yy diameter times_observed
// (diameter "nan" when unknown; doubles written to round-trip exactly).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"  // MapLandmark

namespace ekf_slam {

/// One landmark of a map file.
struct MapEntry {
  LandmarkId id;
  Eigen::Vector2d position;
  Eigen::Matrix2d cov;
  LandmarkInfo info;  ///< diameter and times observed (created_scan -1: loaded)
};

/// Writes `map` (positions, covariances) with the book's diameter and times observed by id.
/// Throws std::runtime_error when the file cannot be written.
void writeMapFile(const std::string& path, const std::vector<MapLandmark>& map,
                  const LandmarkBook& book);
/// Reads a map file; throws std::runtime_error naming the file and line of the first problem
/// (header, field count, a bad number, a covariance that is not one, a duplicate id).
std::vector<MapEntry> readMapFile(const std::string& path);

}  // namespace ekf_slam
