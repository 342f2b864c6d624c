// Lost-robot recovery (docs/relocalisation.md): while lost, each scan goes to the relocaliser
// (alone, or with the scans since going lost carried by the odometry); a fix is held until
// relocalisation_confirmations further fixes agree with it; a probe asks the relocaliser while
// tracking. Recovery returns a fix; the pipeline applies it (the pose replaced, the pairings
// updated) and then tells Recovery, which re-derives the poses of the scans processed while lost
// and of the tracked ones before that the fix contradicts (ScanReport::lost_path).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/filter_backend.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/scan_window.h"
#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/pipeline/lost_scans.h"
#include "ekf_slam/core/pipeline/motion_predictor.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

class Recovery {
 public:
  Recovery(const PipelineConfig& config, const FilterBackend& filter, const MotionPredictor& motion,
           const RangeBearingModel& model, const LandmarkBook& book, PipelineCounters& counters);

  /// The relocaliser (configured already); null switches recovery off (and ends being lost).
  void setRelocaliser(std::shared_ptr<Relocaliser> relocaliser);
  const Relocaliser* relocaliser() const { return relocaliser_.get(); }
  bool active() const { return relocaliser_ != nullptr; }
  bool lost() const { return lost_; }

  /// Freezes the map and hands it to the relocaliser. pose_unknown: no lost_max_scans timeout
  /// (the estimate means nothing), and the tracked scans before say nothing.
  void enterLost(const std::vector<MapLandmark>& map, bool pose_unknown = false);
  /// Not lost, no tracked scans kept (a reset, a new map).
  void reset();
  /// The odometry step about to be predicted: it carries the window, the held fixes and the
  /// newest tracked scan along.
  void carry(const MotionStep& step);

  /// While lost: one relocaliser call on this scan (report->lost). A confirmed fix to apply, or
  /// none; *resumed when tracking resumes unrelocalised (lost_max_scans).
  std::optional<RelocalisationResult> relocalise(ScanReport* report, bool* resumed);
  /// A probe while tracking, in the established map `map`: a fix the filter's estimate does not
  /// cover (a kidnap; report->lost_reason says how far), or none.
  std::optional<RelocalisationResult> probe(const std::vector<MapLandmark>& map,
                                            ScanReport* report);
  /// Whether fix `r` of the last relocaliser call is confirmed (else it is held, counted, and
  /// the report says so).
  bool confirm(const RelocalisationResult& r, ScanReport* report);
  /// The scans processed lost since going lost, with the odometry to now (moved out: at a fix,
  /// for mapping what they saw).
  /// The scans the last relocaliser call used (the fix's update paired them) are left out.
  LostScans takeLostScans() {
    seen_while_lost_.dropFrom(window_first_scan_);
    LostScans out = std::move(seen_while_lost_);
    seen_while_lost_.clear();
    return out;
  }
  /// The first scan undone or processed lost since going lost (`otherwise` when none).
  std::uint32_t firstLostScan(std::uint32_t otherwise) const {
    std::uint32_t first = otherwise;
    if (!seen_while_lost_.empty()) first = std::min(first, seen_while_lost_.scans().front().scan);
    if (!lost_path_.empty()) first = std::min(first, lost_path_.front().scan);
    return first;
  }
  /// Just gone lost: tracked scans whose updates were undone (a rollback) join the lost scans.
  void keepLostScans(LostScans scans) { seen_while_lost_ = std::move(scans); }
  /// A window's older pairings, carried into the current scan, for the fix's update.
  std::vector<Pairing> takeWindowPairings();
  /// The pipeline applied a fix (the pose was `dead_reckoned` before): tracking resumes, and
  /// report->lost_path gets the re-derived poses.
  void fixed(const Eigen::Vector3d& dead_reckoned, ScanReport* report);
  /// Remembers the scan's pose: on the lost path while lost, else as a tracked scan a later fix
  /// may contradict.
  void rememberPose(const ScanReport& report);

  static bool usable(const RelocalisationResult& r, std::size_t n);

 private:
  // A fix awaiting confirmation (relocalisation_confirmations): its pose, the estimate at that
  // scan, how many agreeing fixes it has had, and the newest scan it used.
  struct HeldFix {
    Eigen::Vector3d pose;
    Eigen::Vector3d estimate;
    int count;
    std::uint32_t last_scan;
    Eigen::Matrix3d covariance;  // the fix's
    Eigen::Matrix3d Q;           // the current estimate's given `estimate` (odometry, map frame)
  };
  // A tracked scan of the last lost_recent_scans (the horizon within which rule and probe take
  // a kidnap to have happened, as the discarded recent landmarks), frozen while lost: at the fix
  // those whose estimate the fix carried back by the odometry contradicts are re-derived too.
  struct TrackedPose {
    std::uint32_t scan;
    double stamp;
    std::int64_t informative;  // informative scans at the scan (lost_recent_informative)
    Eigen::Vector3d pose;      // the estimate after the scan's update
    Eigen::Matrix3d covariance;
    Eigen::Vector3d odometry;  // MotionPredictor::odometry() at the scan
    // The odometry from this scan to the next one's (the newest: to now), composed as the
    // pending motion: next = f(this), F = df/dthis, Q its noise (map frame). One composition
    // per prediction, into the newest only; rederiveTracked chains them.
    Eigen::Matrix3d F;
    Eigen::Matrix3d Q;
  };

  RelocalisationResult callRelocaliser(ScanReport* report);
  /// One relocaliser call on the window (the current scan last); returns the current scan's part.
  RelocalisationResult relocaliseWindow(ScanReport* report);
  // Whether fix r agrees with held fix h moved by the odometry to the current estimate.
  bool agrees(const HeldFix& h, const RelocalisationResult& r) const;
  bool confirmedFix(const RelocalisationResult& r, std::uint32_t first_scan,
                    std::uint32_t last_scan);
  // At a fix (the pose already updated, `dead_reckoned` the estimate before): the newest tracked
  // scans whose estimate disagrees with the fix carried back, oldest first.
  std::vector<LostPathPose> rederiveTracked(const Eigen::Vector3d& dead_reckoned) const;

  const PipelineConfig& config_;
  const FilterBackend& filter_;
  const MotionPredictor& motion_;
  const RangeBearingModel& model_;
  const LandmarkBook& book_;
  PipelineCounters& counters_;

  std::shared_ptr<Relocaliser> relocaliser_;
  bool lost_ = false;
  bool pose_unknown_ = false;
  int lost_scans_ = 0;            // relocalisation attempts since lost
  std::uint32_t scans_lost_ = 0;  // scans processed lost since going lost (for the report)
  // Oldest first, at most relocalisation_held_fixes.
  std::vector<HeldFix> held_;
  // relocalisation_window_scans > 1: the scans since going lost; the carried observations the
  // last window call paired, ready for the update, and the window's oldest scan.
  ScanWindow window_;
  std::vector<Pairing> window_pairings_;
  std::uint32_t window_first_scan_ = 0;
  // The dead-reckoned pose of each scan since going lost (at most kMaxLostPath, the newest).
  std::deque<LostPathPose> lost_path_;
  std::deque<TrackedPose> tracked_;
  // lost_map_scans: what the scans processed lost saw (LostScans).
  LostScans seen_while_lost_;
};

}  // namespace ekf_slam
