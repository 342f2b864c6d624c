// The filter's map as it was before a suspect scan (lost_rollback; docs/relocalisation.md,
// "Rolling back to before the kidnap"). A kidnap is rarely called lost at its first scan, and the
// scans tracked at the wrong pose in between move the map and make the associator drop landmarks
// it expected to see. Held while the scans since pair few observations with established
// landmarks; at a lost event the pipeline restores it and hands those scans on as lost scans.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/pipeline/lost_scans.h"

namespace ekf_slam {

struct MapCheckpoint {
  bool held = false;
  std::uint32_t scan = 0;   // the first scan it undoes
  std::int64_t origin = 0;  // scans (or informative scans) then, as LandmarkBook::recent counts
  // The filter's state without clones: mean, covariance (its lower triangle current), ids.
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;
  std::vector<LandmarkId> ids;
  std::unordered_map<LandmarkId, LandmarkInfo> book;
  std::unordered_map<LandmarkId, int> evidence;  // the associator's, for those it would drop
  // The scans since, at their odometry poses (LostScans::reanchor places them at the estimate).
  LostScans scans;
  int established = 0;   // observations paired with established landmarks since ...
  int observations = 0;  // ... of these

  void drop() {
    held = false;
    scans.clear();
    book.clear();
    evidence.clear();
  }
};

}  // namespace ekf_slam
