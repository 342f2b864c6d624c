// What the scans processed while lost saw, kept with the odometry between them, and mapped once a
// fix says where the vehicle is (docs/relocalisation.md, "Nothing seen while lost is thrown
// away"). At the fix the vehicle state is carried back scan by scan through the odometry (an EKF
// prediction with the inverse motion, its noise the odometry's), each lost scan is associated
// against the map by its own gate and updates it, its unmatched observations become landmarks, and
// the pose at the fix is restored from a clone: every landmark gets the correlations of the
// odometry chain with the fixed pose and the map, none a fresh prior.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"  // LostLook
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

class LostScans {
 public:
  struct Scan {
    std::uint32_t scan;
    Eigen::Vector3d pose;  // dead-reckoned when it was processed
    std::vector<Observation> observations;
    // The odometry from this scan to the next kept one (the newest: to now), composed as the
    // predictions were: next = f(this), F = d next / d this, Q its noise (dead-reckoned frame).
    Eigen::Matrix3d F;
    Eigen::Matrix3d Q;
  };

  /// At most this many scans are kept (the oldest go): about 3 minutes of Victoria Park's.
  static constexpr std::size_t kMaxScans = 1000;

  void clear() { scans_.clear(); }
  bool empty() const { return scans_.empty(); }
  const std::deque<Scan>& scans() const { return scans_; }
  /// A scan processed lost, at its dead-reckoned pose (scans without observations are skipped).
  void add(std::uint32_t scan, const Eigen::Vector3d& pose, std::vector<Observation> observations);
  /// An odometry step predicted after the newest kept scan.
  void carry(const MotionStep& step);
  /// Forgets the scans from `scan` on (those a fix already used), their odometry kept.
  void dropFrom(std::uint32_t scan);
  /// Forgets the scans before `scan` (the odometry from the newer ones on is all kept).
  void dropBefore(std::uint32_t scan);
  /// A copy of the scans from `scan` on.
  LostScans from(std::uint32_t scan) const;
  /// Moves every pose by the motion that takes `from` to `to` (scans kept at odometry poses,
  /// then placed at the estimate).
  void reanchor(const Eigen::Vector3d& from, const Eigen::Vector3d& to);

 private:
  std::deque<Scan> scans_;
};

struct LostMappingParams {
  double pair_probability = 0.99;   ///< an observation pairs inside chi2(2, this) of one landmark
  double new_probability = 0.9999;  ///< ... and is new outside chi2(2, this) of every landmark
  int min_sightings = 3;            ///< lost scans a new landmark must be seen in to stay
};

/// What mapLostScans did: the landmarks it created and kept (with their sightings and mean
/// descriptor), and the pairings with landmarks already mapped.
struct LostScanMapping {
  std::vector<LandmarkId> created;
  std::vector<std::uint32_t> sightings;
  /// Per created landmark: every lost scan carried back to, oldest first, with whether it saw the
  /// landmark and where it lay in that scan's sensor frame (its final estimate, the scan's
  /// carried-back pose).
  std::vector<std::vector<LostLook>> looks;
  std::vector<double> descriptors;  // NaN when unknown
  std::vector<LandmarkId> paired;   // landmarks of the map before, once per pairing
  /// Per scan carried back to, newest first: the vehicle's pose there after its update.
  std::vector<std::pair<std::uint32_t, Eigen::Vector3d>> poses;
  /// ... and the landmarks its observations were paired with there.
  std::vector<std::vector<LandmarkId>> paired_at;
  int scans = 0;    // scans carried back to
  int dropped = 0;  // new landmarks seen too few times, removed again
};

/// Maps `lost` into `ekf`, whose pose is the fixed one at the scan after the newest lost scan
/// and `dead_reckoned_now` the estimate there before the fix. The pose is the same afterwards
/// (restored from a clone). The full filter only (a compressed one: flush first, restart after).
/// Each scan's candidates come from `index` (synced with `ekf` before each scan, so in step with
/// it on return but for the clutter removed at the end); without one, a local index is built.
LostScanMapping mapLostScans(EkfSlam& ekf, const RangeBearingModel& model, const LostScans& lost,
                             const Eigen::Vector3d& dead_reckoned_now,
                             const LostMappingParams& params, LandmarkIndex* index = nullptr);

}  // namespace ekf_slam
