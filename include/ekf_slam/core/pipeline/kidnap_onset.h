// Where a kidnap began, found at its fix (lost_onset_scans; docs/relocalisation.md, "A kidnap
// found late"). A kidnap into a place the filter takes for new ground can go unnoticed for
// minutes: the filter maps an island of landmarks at the wrong pose and pairs them as it goes.
// The lost rules see it only when the vehicle comes back among mapped landmarks and the
// relocaliser fixes it there. The fix alone cannot say when the kidnap happened; the scans can.
// Carried back from the fix by their odometry, the scans after the kidnap are explained by the
// map as it was before it (or by nothing: new ground), while at the filter's poses they are
// explained only by the island. The scans before the kidnap are explained at the filter's poses.
//
// For a candidate onset k the score is, over the kept scans from k on, the observations that pair
// a landmark made before k at the carried-back pose, minus those that pair one at the filter's
// pose. It grows while k moves back over the island (its landmarks stop counting for the filter)
// and stops growing at the kidnap (before it the filter's poses explain the scans). The onset is
// the latest k with the highest score. TrackedHistory keeps what that needs, and the filter's
// state at a few scans to roll back to.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/lost_scans.h"
#include "ekf_slam/core/pipeline/map_checkpoint.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

/// A landmark as the onset test sees it: where it is now, and the scan that made it (-1: loaded
/// from a map file, older than every scan).
struct OnsetLandmark {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  std::int64_t created_scan = -1;
};

/// A kept scan under both hypotheses: the pose the filter tracked, and the fix carried back.
struct OnsetScan {
  std::uint32_t scan = 0;
  Eigen::Vector3d estimate = Eigen::Vector3d::Zero();
  Eigen::Matrix3d estimate_covariance = Eigen::Matrix3d::Zero();
  Eigen::Vector3d carried = Eigen::Vector3d::Zero();
  Eigen::Matrix3d carried_covariance = Eigen::Matrix3d::Zero();
  const std::vector<Observation>* observations = nullptr;
};

struct KidnapOnset {
  bool found = false;
  std::uint32_t scan = 0;  ///< the first scan the kidnap took (the onset)
  double score = 0.0;      ///< log-likelihood ratio of the scans from it on: carried back : filter
};

struct OnsetParams {
  double pair_probability = 0.99;  ///< an observation pairs inside chi2(2, this)
  double max_range = 30.0;         ///< the sensor's reach [m] ...
  double field_of_view = M_PI;     ///< ... and field of view [rad]: a new feature's density
  double min_score = 10.0;         ///< the least log-likelihood ratio of an onset
};

/// The onset among the scans of `scans` (oldest first), or none when no candidate scores at
/// least params.min_score. Under each hypothesis an observation pairs the nearest landmark (by
/// the Mahalanobis distance) within chi2(2, pair_probability), each landmark once a scan, and
/// weighs log(N(innovation; S) / new-feature density) when that is positive (a landmark made
/// at or after the candidate onset explains nothing for it).
KidnapOnset estimateKidnapOnset(const std::vector<OnsetScan>& scans,
                                const std::vector<OnsetLandmark>& landmarks,
                                const RangeBearingModel& model, const OnsetParams& params);

/// The tracked (and lost) scans of the last `max_scans`, at their odometry poses with the
/// odometry between them (as LostScans keeps them), the filter's pose at each, and the filter's
/// state at every `spacing`-th of them (MapCheckpoint) to roll back to.
class TrackedHistory {
 public:
  struct Record {
    std::uint32_t scan;
    double stamp;
    Eigen::Vector3d odometry;
    Eigen::Vector3d estimate;
    Eigen::Matrix3d covariance;
    bool tracked;  // false: processed lost (no pose of the filter's to test)
  };

  /// max_scans 0: off (nothing is kept).
  void configure(int max_scans, int snapshots);
  bool active() const { return max_scans_ > 0; }
  void clear();

  /// A processed scan (observations may be empty: its pose is still re-derived at a fix).
  void add(const Record& record, const std::vector<Observation>& observations);
  /// An odometry step predicted after the newest scan.
  void carry(const MotionStep& step) { scans_.carry(step); }
  /// Whether the filter's state before tracked scan `scan` should be kept.
  bool wantsSnapshot(std::uint32_t scan) const;
  void addSnapshot(MapCheckpoint snapshot);
  /// The map was rolled back to before `scan`: the states kept from it on are of an undone past,
  /// and the filter's poses from it on are no hypothesis any more (the scans were mapped lost).
  void forgetFrom(std::uint32_t scan);
  /// The newest state kept at or before `scan`, or null.
  const MapCheckpoint* snapshotAtOrBefore(std::uint32_t scan) const;

  /// The tracked scans with observations before scan `before`, oldest first, under both
  /// hypotheses: the filter's pose then, and `fix` (covariance `fix_covariance`, at odometry
  /// pose `odometry_now`) carried back by the odometry with its chain's noise, turned from the
  /// frame of an estimate with heading `estimate_yaw` (as Recovery::rederiveTracked). Valid while
  /// the history is unchanged (they point to its observations).
  std::vector<OnsetScan> hypotheses(const Eigen::Vector3d& fix,
                                    const Eigen::Matrix3d& fix_covariance,
                                    const Eigen::Vector3d& odometry_now, double estimate_yaw,
                                    std::uint32_t before) const;
  /// The kept scans from `from` to before `until` at their odometry poses moved by `to_fixed`
  /// (a fix's frame), as re-derived tracked poses of a lost path.
  std::vector<LostPathPose> path(std::uint32_t from, std::uint32_t until,
                                 const Eigen::Vector3d& to_fixed) const;

  const std::deque<Record>& records() const { return records_; }
  /// The kept scans with observations, the odometry from each to the next and to now.
  const LostScans& scans() const { return scans_; }

 private:
  int max_scans_ = 0;
  int spacing_ = 1;
  std::deque<Record> records_;
  LostScans scans_;
  std::deque<MapCheckpoint> snapshots_;
  std::int64_t last_snapshot_ = -1;
};

}  // namespace ekf_slam
