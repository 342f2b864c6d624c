// When is the filter lost? The lost rules of docs/relocalisation.md, judged scan by scan on what
// the association and the update did:
//   rule 1: observations, yet no established (not recent) landmark paired, for several scans,
//           with enough of the established map in view;
//   rule 2: the batch NIS above its chi2 bound for several scans;
//   rule 3: the associator recognised landmarks without the pose that the filter's gate refused,
//           more than it paired (only associators that fill gate_refused: RRWSC);
//   rule 4: over a window of scans, too few observations explained by established landmarks.
// With too little in view to judge (or rule 4's share on one scan), the relocaliser is asked
// instead (a probe). The monitor only judges; the pipeline acts on its verdict.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <utility>

#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/sensor_model.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

class LostMonitor {
 public:
  enum class Verdict : std::uint8_t { kTracking, kLost, kProbe };
  enum class Refusal : std::uint8_t {
    kNone,      ///< rule 3 does not apply
    kSuppress,  ///< its streak runs: the scan makes no new landmark
    kProbe,     ///< its streak is complete: ask the relocaliser on this scan
  };

  LostMonitor(const PipelineConfig& config, const EkfSlam& filter, const LandmarkIndex& index,
              const RangeBearingModel& model, const LandmarkBook& book);

  /// Rules 1, 2 and 4 after a tracked scan's update; kLost sets report->lost_reason. Fills
  /// report->landmarks_expected where a rule needed it.
  Verdict afterUpdate(ScanReport* report);
  /// Before a tracked scan's update: it pairs under lost_established_share of its observations
  /// (or none, or rule 1's share) with established landmarks while some are in view: a kidnap
  /// may have begun (lost_rollback). *established: its observations paired with them.
  bool suspect(const ScanReport& report, int* established) const;
  /// Rule 3 on a scan's association, before it is applied; *reason says why for kProbe.
  Refusal refused(const ScanReport& report, std::string* reason);
  /// The relocaliser agreed with the estimate on rule 3's probe: the streak ends.
  void refusalAnswered() { refused_streak_ = 0; }
  /// Going lost: every streak starts again.
  void restart();
  /// A new run: also the learned shares (lost_share_learning_scans) start again.
  void reset();
  /// Tracking resumes (relocalised, or lost too long): rules 1 and 2 start again.
  void resume() { unpaired_streak_ = nis_streak_ = 0; }

  /// Established (not recent) map landmarks in view of the sensor at the estimated pose.
  int landmarksInView(std::uint32_t scans) const;
  /// Rule 3's doubt: the scan's kNew decisions become kRejected (counted as suppressed_new).
  static void suppressNew(AssociationResult* association, PipelineCounters* counters);

 private:
  const PipelineConfig& config_;
  const EkfSlam& filter_;
  const LandmarkIndex& index_;
  const RangeBearingModel& model_;
  const LandmarkBook& book_;
  Chi2Table nis_chi2_;
  SensorModel view_;  // lost_view_polygon, for "in view"
  int unpaired_streak_ = 0;
  int nis_streak_ = 0;
  int refused_streak_ = 0;
  std::deque<std::pair<int, int>> share_window_;  // rule 4: (established paired, observations)
  // Rule 1 with lost_min_paired_share: the learned shares of the established landmarks in view,
  // and of the observations not paired with recent landmarks, paired with established ones.
  double seen_rate_;
  double explained_rate_;
  int seen_samples_ = 1;  // scans in each mean so far, the prior's one included
  int explained_samples_ = 1;
  double learnedShare(double rate) const;
};

}  // namespace ekf_slam
