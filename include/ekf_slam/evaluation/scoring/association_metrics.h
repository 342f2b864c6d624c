// Scoring data association and pose estimates against ground truth (ALGORITHMS.md section 9;
// seed 003 section 3.1; seed 001 paper 5). ROS-free. The offline runner feeds it per scan when
// the observations carry truth ids (simulated worlds); see docs/simulation.md.
//
//   AssociationScorer scorer;
//   ... per scan, after the pipeline ran:
//   scorer.addScan(truth_ids, report.association, report.removed);  // kNew carries the new id
//   scorer.counts().accuracy();  scorer.mapScore().spurious;
//
// Per observation (positive = paired with an existing map landmark):
//   TP  paired with the landmark whose identity is the observation's truth (the oldest one when
//       several share it: the true landmark's representative);
//   FP  paired with a landmark of another identity or with a younger duplicate of the right one,
//       or a mover / clutter return paired at all;
//   FN  a static landmark's return left unpaired (new / tentative / rejected) although some map
//       landmark already has that identity;
//   TN  anything else left unpaired (a landmark not in the map yet, a mover, clutter).
// A map landmark's identity is the majority truth of the observations that created and updated
// it (ties keep the current identity). Every observation of a scan is judged against the
// identities as they stood before the scan.
#pragma once

#include <cstdint>
#include <limits>
#include <set>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/ekf_slam.h"

namespace ekf_slam {

enum class Outcome : std::uint8_t { kTruePositive, kFalsePositive, kFalseNegative, kTrueNegative };
const char* toString(Outcome o);

struct AssociationCounts {
  std::uint64_t tp = 0, fp = 0, fn = 0, tn = 0;

  std::uint64_t total() const { return tp + fp + fn + tn; }
  /// (TP + TN) / all; 1 when nothing was judged.
  double accuracy() const;
  /// TP / (TP + FP); 1 when nothing was paired (no claim made, so none was wrong).
  double precision() const;
  /// TP / (TP + FN); 1 when nothing should have been paired.
  double recall() const;
  /// 2 P R / (P + R); 0 when P + R = 0.
  double f1() const;
  void add(Outcome o);
  AssociationCounts& operator+=(const AssociationCounts& o);
};

/// The final map against the truth.
struct MapScore {
  std::size_t landmarks = 0;              ///< landmarks in the map now
  std::size_t true_landmarks_mapped = 0;  ///< distinct static landmarks that some landmark is
  std::size_t true_landmarks_seen = 0;    ///< distinct static landmarks observed at all
  std::size_t non_landmarks = 0;          ///< identity is a mover or clutter
  std::size_t duplicates = 0;             ///< extra landmarks sharing a static identity
  std::size_t spurious = 0;               ///< non_landmarks + duplicates

  // Landmark-level scores: what the map holds, not how often the associator answered, so that an
  // associator cannot score by withholding decisions (docs/simulation.md, "Metrics").
  std::uint64_t landmarks_created = 0;  ///< landmarks the run created (kNew), removed ones too
  /// Static landmarks observed at least kMinObservationsToFind times (the recall's denominator).
  std::size_t true_landmarks_findable = 0;
  /// Of those, the ones exactly one final landmark holds (no duplicate, not missing).
  std::size_t true_landmarks_found = 0;
  /// Final landmarks that are the only holder of a static landmark / all final landmarks (1
  /// for an empty map: it claims nothing).
  double landmark_precision = 1.0;
  /// true_landmarks_found / true_landmarks_findable (1 when nothing was findable).
  double landmark_recall = 1.0;
  /// Share of the observations of the true landmarks the final map holds that were paired with
  /// that landmark's representative (TP): withheld, tentative and wrongly paired ones all count
  /// against it. The observation that created a landmark counts too, so 1 is out of reach.
  double pairing_coverage = 1.0;
  /// Share of the same observations that entered the filter on that representative: paired with
  /// it (TP), created it, or applied when it was created (an earlier sighting kept back,
  /// core/pipeline/delayed_sightings.h). The observations the filter's estimate rests on.
  double sightings_used = 1.0;
};

/// A true landmark counts as findable (landmark recall) once observed this often.
constexpr std::uint32_t kMinObservationsToFind = 3;

class AssociationScorer {
 public:
  /// Scores one scan. truth[i] is the source of observation i (>= 0 a static landmark, < 0 a
  /// mover or clutter). decision / landmark as in AssociationResult, except that for kNew
  /// `landmark[i]` is the id the pipeline gave the new landmark (kNoLandmark if none was made).
  /// `removed`: landmarks deleted after this scan. Optionally returns each observation's
  /// outcome. Returns this scan's counts (also added to counts()). Throws std::invalid_argument
  /// when the sizes differ.
  AssociationCounts addScan(const std::vector<LandmarkId>& truth,
                            const std::vector<Decision>& decision,
                            const std::vector<LandmarkId>& landmark,
                            const std::vector<LandmarkId>& removed,
                            std::vector<Outcome>* outcomes = nullptr);
  AssociationCounts addScan(const std::vector<LandmarkId>& truth, const AssociationResult& result,
                            const std::vector<LandmarkId>& removed,
                            std::vector<Outcome>* outcomes = nullptr) {
    return addScan(truth, result.decision, result.landmark, removed, outcomes);
  }

  /// Earlier observations of sources `truth` applied to `landmark` when the last scan created it
  /// (ScanReport::delayed_sightings): counted in MapScore::sightings_used.
  void addDelayedSightings(const std::vector<std::pair<LandmarkId, LandmarkId>>& landmark_truth);

  /// A landmark that entered the map without a scored observation (e.g. a loaded map), with its
  /// known identity.
  void addKnownLandmark(LandmarkId id, LandmarkId truth);
  void reset();

  const AssociationCounts& counts() const { return counts_; }
  std::uint64_t scans() const { return scans_; }
  /// Pairings with a landmark the scorer never saw created (scored FP: unverifiable); the
  /// landmark is tracked from then on.
  std::uint64_t unknownPairings() const { return unknown_pairings_; }
  /// Pairings scored FP because they went to a younger duplicate of the right landmark.
  std::uint64_t duplicatePairings() const { return duplicate_pairings_; }
  /// Times a landmark's majority identity changed.
  std::uint64_t identitySwitches() const { return identity_switches_; }
  /// Majority identity of map landmark `id`; false when it is not tracked.
  bool identity(LandmarkId id, LandmarkId* truth) const;
  MapScore mapScore() const;

 private:
  struct Track {
    std::vector<std::pair<LandmarkId, std::uint32_t>> votes;  ///< (truth, count), few entries
    LandmarkId identity = 0;
  };
  void vote(LandmarkId id, LandmarkId truth);
  void setIdentity(LandmarkId id, Track* t, LandmarkId truth, bool is_new);

  std::unordered_map<LandmarkId, Track> tracks_;
  /// truth -> the map landmarks that have it as identity, oldest (lowest id) first.
  std::unordered_map<LandmarkId, std::set<LandmarkId>> holders_;
  /// Per static truth observed: its observations and how many were TP.
  struct TruthTally {
    std::uint32_t observations = 0;
    std::uint32_t true_positives = 0;
    std::uint32_t used = 0;  ///< entered the filter on the landmark's representative
  };
  /// The representative of `truth` (its oldest holder) is `id`.
  bool represents(LandmarkId id, LandmarkId truth) const;
  void countUsed(LandmarkId id, LandmarkId truth);
  std::unordered_map<LandmarkId, TruthTally> seen_;
  std::uint64_t landmarks_created_ = 0;
  AssociationCounts counts_;
  std::uint64_t scans_ = 0;
  std::uint64_t unknown_pairings_ = 0;
  std::uint64_t identity_switches_ = 0;
  std::uint64_t duplicate_pairings_ = 0;
};

// --- pose accuracy and consistency
// ----------------------------------------------------------------

/// NEES (x - x_true)^T P^-1 (x - x_true) of a pose (heading error wrapped); NaN when P is not
/// positive definite or anything is not finite.
double poseNees(const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                const Eigen::Vector3d& truth);

/// Pose RMSE (position and heading separately) and mean NEES over the scans of one run.
class PoseErrorStats {
 public:
  /// Adds one scan's estimate; returns its NEES (NaN ones are counted in invalidNees()).
  double add(const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
             const Eigen::Vector3d& truth);
  std::size_t count() const { return n_; }
  double positionRmse() const;  ///< [m]
  double headingRmse() const;   ///< [rad]
  double meanNees() const;      ///< over the valid NEES values
  std::size_t invalidNees() const { return invalid_nees_; }
  void reset() { *this = PoseErrorStats(); }

 private:
  std::size_t n_ = 0, nees_n_ = 0, invalid_nees_ = 0;
  double sum_pos2_ = 0.0, sum_yaw2_ = 0.0, sum_nees_ = 0.0;
};

/// Two-sided band of the average NEES of `runs` runs of a `dof`-dimensional state:
/// [chi2^-1((1 - p) / 2, runs dof), chi2^-1((1 + p) / 2, runs dof)] / runs. For 50 runs of a pose
/// (dof 3) at p = 0.95: [2.36, 3.72] (ALGORITHMS.md section 8).
struct NeesBand {
  double lower = 0.0, upper = 0.0;
  bool contains(double anees) const { return anees >= lower && anees <= upper; }
};
NeesBand neesBand(int runs, int dof = 3, double probability = 0.95);

/// Average NEES (ANEES) per scan index over Monte Carlo runs.
class MonteCarloNees {
 public:
  /// NEES of run r at scan index `scan` (runs may differ in length; NaN values are ignored).
  void add(std::size_t scan, double nees);
  std::size_t scans() const { return sum_.size(); }
  /// Runs that contributed at scan `scan`.
  int runs(std::size_t scan) const { return scan < n_.size() ? n_[scan] : 0; }
  /// Mean over the runs at scan `scan` (NaN when none).
  double average(std::size_t scan) const;
  /// Share of scans whose ANEES lies in the band for their number of runs.
  double fractionInBand(int dof = 3, double probability = 0.95) const;

 private:
  std::vector<double> sum_;
  std::vector<int> n_;
};

}  // namespace ekf_slam
