// DJNN as seed 000 (section 3) states it; read beside ALGORITHMS.md section 4:
//   1. the local region (eq. 10) around the sensor, and its valid part (eq. 7);
//   2. nearest neighbour within the individual gate (eq. 4), by the normalised distance (eq. 5);
//   3. interference: when observations compete for a landmark, the observation compensation v_bar
//      (eq. 6; case 4: one pair within the wide gate, eq. 8) and NN again, cases 1-4;
//   4. the evidence counter T (eq. 9) of every map landmark in the local region (+1 seen, -1
//      missed inside the sensor region; removed at remove_evidence) and of every feature not in
//      the map (tentative; admitted at admit_evidence).
// Where the paper is open (docs/djnn.md, "Decisions where the paper is open") the choices are
// parameters: penalty_region, tentative_timeout, the tentative gate. The counter's steps are the
// paper's +-1 for a sensor that sees everything in its region without clutter (P_D = 1); for
// other sensors EvidenceModel weighs them (the "detection probability" extension).
//
// The package's extensions change the tentative-feature step only through FeatureRules
// (djnn.cpp implements it with the named extension components); with every extension off the
// rules are the paper's.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/common/sensor_model.h"

namespace ekf_slam {

/// Which interference case of seed 000 section 3 the last scan started in.
enum class DjnnCase : std::uint8_t {
  kNone = 0,            ///< no association ran (empty scan)
  kNoInterference = 1,  ///< case 1: NN result accepted
  kPartial = 2,         ///< case 2: p > 0 unique pairs, k interfering
  kAllInterfere = 3,    ///< case 3: every pairing interferes (p = 0)
  kNothingPaired = 4,   ///< case 4: no observation paired
};

/// Counters since configure()/reset(), for tests and diagnostics.
struct DjnnStats {
  std::uint64_t scans = 0;              ///< associate() calls with at least one observation
  std::uint64_t cases[5] = {};          ///< indexed by DjnnCase
  std::uint64_t case4_accepted = 0;     ///< case 4, no landmark in the valid region (eq. 7)
  std::uint64_t case4_compensated = 0;  ///< case 4, a wide-gate pair (eq. 8) gave v_bar
  std::uint64_t resolution_rounds = 0;  ///< interference-resolution rounds, all cases
  std::uint64_t admitted = 0;           ///< kNew decisions
  std::uint64_t removed = 0;            ///< landmarks returned in result.remove
  std::uint64_t tentative_dropped = 0;
  std::uint64_t tentative_withheld =
      0;  ///< sightings withheld near a tentative feature (tentative_ambiguity)
  std::uint64_t static_restarts = 0;      ///< tentative features restarted by the static test
  std::uint64_t biased_removed = 0;       ///< landmarks removed by the innovation-bias test
  std::uint64_t biased_kept = 0;          ///< pairings withdrawn from established landmarks
  std::uint64_t density_withdrawn = 0;    ///< pairings withdrawn by the density test
  std::uint64_t joint_scans = 0;          ///< loop-closure scans given the joint decision
  std::uint64_t joint_held = 0;           ///< observations the joint decision left undecided
  std::uint64_t joint_incomplete = 0;     ///< joint searches over budget (scan held)
  std::uint64_t remembered = 0;           ///< tentative features remembered at their timeout
  std::uint64_t remembered_admitted = 0;  ///< observations admitted on a remembered feature
  /// Of `remembered`: seen with no landmark to anchor to, anchored at the timeout.
  std::uint64_t remembered_late_anchor = 0;
  /// Admissions refused: the source lay within landmark_spacing of a map landmark.
  std::uint64_t spacing_refused = 0;
  std::uint64_t held_streaks = 0;       ///< runs of held joint scans that ended
  std::uint64_t held_streak_scans = 0;  ///< scans in those runs
  /// Misses not counted: the landmark was hidden behind a nearer return (OccludedMisses).
  std::uint64_t hidden_misses = 0;
  /// Features born held that joined the landmark a later sighting paired (HeldSightings).
  std::uint64_t held_joined = 0;
  /// Observations the optimal assignment gave another landmark than the paper's resolution.
  std::uint64_t reassigned = 0;
  /// Observations the paper left unpaired that the optimal assignment paired (assign_unpaired).
  std::uint64_t unpaired_assigned = 0;
};

/// The paper's parameters (names as read; defaults in docs/djnn.md).
struct DjnnPaperParams {
  /// R (sensor_range) and the field of view of eq. 10; the sensor's minimum range, polygon,
  /// detection probability P_D and clutter density extend it to other sensors.
  SensorModel sensor;
  double range_margin = 3.0;  ///< d [m]
  double angle_margin = 0.1;  ///< dphi [rad]
  double individual_probability = 0.999;
  double wide_gate_factor = 3.0;  ///< eq. 8
  int admit_evidence = 7;
  int remove_evidence = 0;
  int initial_evidence = 2;  ///< T of map landmarks DJNN has not seen yet
  double tentative_gate_probability = 0.95;
  double tentative_timeout = 60.0;  ///< [s] of stamp; 0 disables
  /// Where a missed feature scores r_k = -1 (eq. 9): "sensor" = range R and the field of view;
  /// "valid" = the valid region of eq. 7 (shrunk by the margins).
  std::string penalty_region = "sensor";

  void read(const ParameterReader& r);
};

/// The evidence steps r_k of eq. 9. The paper's counter tests "hit rate above 1/2", the midpoint
/// between the hit rate of a real landmark (1) and of a pseudo-feature (0). With detection
/// probability P_D and a false-detection chance P_F in the feature's gate the threshold becomes the
/// midpoint tau = (P_D + P_F) / 2, and T = 2 (hits - tau scans): the same units, so admit / remove
/// thresholds keep their meaning (docs/djnn.md, "Detection probability").
class EvidenceModel {
 public:
  void configure(const SensorModel& sensor, double tentative_gate);
  /// r_k of a feature seen (hit) or missed, with position covariance C: 2 (1 - tau), -2 tau;
  /// +1 / -1 for P_D = 1 without clutter. `detectable`: the share of P_D the sensor had at the
  /// feature (the beams' spacing, BeamSpacingMisses); P_D times it is this feature's P_D.
  double step(bool hit, const Eigen::Matrix2d& C, double detectable = 1.0) const;
  /// The sensor's P_D from now on (DetectionEstimate), the rest of its model kept.
  void setDetectionProbability(double pd) { sensor_.detection_probability = pd; }

 private:
  SensorModel sensor_;
  double tentative_gate_ = 0.0;
};

/// An unpaired observation of the scan as a candidate feature (eq. 9).
struct Sighting {
  Eigen::Vector2d pos;            ///< inverse model at the current pose
  Eigen::Matrix2d cov_obs;        ///< G_z R G_z^T
  Eigen::Vector2d heading_lever;  ///< d pos / d heading (column 2 of G_x)
  int slot;                       ///< tentative feature it matched, or -1
  bool eligible;
  double detectable = 1.0;  ///< FeatureRules::detectable at its range
};

/// Where the extensions change the paper's step for features not in the map.
class FeatureRules {
 public:
  virtual ~FeatureRules() = default;
  /// The sighting's covariance for the gate with a tentative feature, and the variance of the
  /// heading whose lever difference is added (the paper: the observation noise plus the pose
  /// covariance G_x P G_x^T once, no lever term).
  virtual Eigen::Matrix2d gateCovariance(const Eigen::Matrix2d& cov_obs, const Matrix23d& G_pose,
                                         const Eigen::Matrix3d& P_vv, double* lever_var) const = 0;
  /// The share of P_D the sensor had at `range` [m] in this scan (the paper: 1).
  virtual double detectable(const AssociationContext& ctx, double range) const = 0;
  /// A gate wider than the tentative one (chi2 value; the paper: 0, none): a sighting within it
  /// of a feature it did not pair with is withheld.
  virtual double withholdGate() const = 0;
  /// A sighting `s` (observation `obs`, noise C) of feature t: false when it shows t is no
  /// static point, which then restarts from this sighting (the paper: always true).
  virtual bool stillStatic(const AssociationContext& ctx, int obs, Tentative* t, const Sighting& s,
                           const Eigen::Matrix2d& C, double stamp) = 0;
  /// Feature t (re)starts from sighting z (noise C).
  virtual void started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                       double stamp) = 0;
  /// Feature `slot` is dropped; `stale`: it timed out with evidence left.
  virtual void dropping(const AssociationContext& ctx, int slot, bool stale) = 0;
  /// Observation `obs` was matched to feature `slot` in this scan, or started it (`born`).
  virtual void sighted(const AssociationContext& ctx, int slot, int obs, bool born) = 0;
  /// The decision (kNew or kTentative) on observation `obs` whose feature `slot` has evidence
  /// `evidence`; `paper_admits`: the paper's rule (T >= admit_evidence).
  virtual Decision decide(const AssociationContext& ctx, int obs, int slot, double evidence,
                          bool paper_admits) = 0;
};

class DjnnPaper {
 public:
  void configure(const DjnnPaperParams& params);
  const DjnnPaperParams& params() const { return p_; }
  /// P_D of the evidence steps from now on (DetectionEstimate: estimated online when not set).
  void setDetectionProbability(double pd);
  /// P_D the evidence steps count with now (stated, or DetectionEstimate's).
  double detectionProbability() const { return p_.sensor.detection_probability; }
  double gate() const { return gate_; }
  double tentativeGate() const { return tentative_gate_; }
  /// p_sensor inside the sensor region grown by `radial` [m] in range and `lateral` [m] across
  /// its edges (negative: shrunk).
  bool inRegion(const Eigen::Vector2d& p_sensor, double radial, double lateral) const {
    return p_.sensor.contains(p_sensor, radial, lateral);
  }
  /// Where a miss counts (penalty_region).
  bool inPenaltyRegion(const Eigen::Vector2d& p_sensor) const {
    return inRegion(p_sensor, penalty_radial_, penalty_lateral_);
  }
  /// Whether the scan looked at candidate slot k where the evidence counter counts a miss: the
  /// scan not held, the landmark in the penalty region and not hidden (OccludedMisses).
  bool looksAt(const AssociationContext& ctx, const LocalScan& scan, int k) const {
    return !scan.held && !scan.isHidden(k) &&
           inPenaltyRegion(inSensorFrame(scan, ctx.ekf().landmark(scan.cand[k])));
  }
  /// A point (map frame) in the frame of the scan's sensor.
  static Eigen::Vector2d inSensorFrame(const LocalScan& scan, const Eigen::Vector2d& p);
  /// Observation `obs` as a sighting from `pose` (s->pos, cov_obs, heading_lever) and the
  /// covariance it is gated with against a tentative feature (FeatureRules::gateCovariance, with
  /// its `lever_var`).
  static Eigen::Matrix2d sightingGate(const AssociationContext& ctx, int obs,
                                      const Eigen::Vector3d& pose, const Eigen::Matrix3d& P_vv,
                                      const FeatureRules& rules, Sighting* s, double* lever_var);
  /// The tentative gate's statistic d^2 of a sighting at `pos` with heading lever `lever` and
  /// gate covariance `C` (FeatureRules::gateCovariance, with its `lever_var`) against feature t.
  /// A feature in anchored polar form (Tentative::polar) is gated in (range, bearing) instead,
  /// where a far return's precise range still counts.
  static double tentativeDistance2(const AssociationContext& ctx, int obs, const Sighting& s,
                                   const Eigen::Matrix2d& C, double lever_var, const Tentative& t);
  /// Starts the anchored polar form of the feature in `slot` from observation obs where the
  /// filter's second-order terms are on and obs is a range-bearing return (else t.polar = false).
  void startPolar(const AssociationContext& ctx, int obs, int slot);
  /// Fuses sighting s of observation obs (C: its noise in the map frame) into t:
  /// information-weighted in the map frame, or, in polar form, as a measurement update in (range,
  /// bearing). Returns t's new position; the caller moves t there (TentativeSet::move).
  static Eigen::Vector2d fuseSighting(const AssociationContext& ctx, int obs, const Sighting& s,
                                      const Eigen::Matrix2d& C, Tentative* t);

  /// 1. The local region (eq. 10) and its valid part (eq. 7): scan->cand, cand_valid.
  void localRegion(const AssociationContext& ctx, LocalScan* scan) const;
  /// 2. NN within the gate (eq. 4-5): scan->assign, gated (passed the gate).
  void nearestNeighbours(const AssociationContext& ctx, LocalScan* scan) const;
  /// 3. Interference (cases 1-4, eq. 6-8): the final NN pairing of scan->assign, v_bar.
  DjnnCase resolveInterference(const AssociationContext& ctx, LocalScan* scan,
                               DjnnStats* stats) const;
  /// Eq. 5 of observation `obs` compensated by v_bar with candidate `cand`; *mahalanobis gets the
  /// compensated M_ij.
  double score(const LocalScan& scan, int obs, int cand, const Eigen::Vector2d& v_bar,
               double* mahalanobis) const;

  /// 4a. The evidence of the local region's map landmarks: paired ones +r, missed ones inside the
  /// penalty region -r (none when the scan is held or the landmark is scan.hidden); at
  /// remove_evidence into result->remove.
  /// Landmarks already in result->remove are skipped.
  void countMapEvidence(const AssociationContext& ctx, const LocalScan& scan,
                        AssociationResult* result, DjnnStats* stats);
  /// 4b. The features not in the map: the eligible unpaired observations matched one-to-one to
  /// tentative features (closest first), fused, counted; missed features counted down and
  /// dropped; decisions (kNew at admission, else kTentative) with their feature keys; stale
  /// features swept; the keys that ended (result->ended_features) and the runs restarted by the
  /// static test (result->restarted_features).
  void countFeatureEvidence(const AssociationContext& ctx, LocalScan* scan,
                            AssociationResult* result, FeatureRules* rules, DjnnStats* stats);

  /// Map landmark evidence.
  void setEvidence(LandmarkId id, double t) { evidence_[id] = t; }
  void forget(LandmarkId id) { evidence_.erase(id); }
  /// T in whole units (initial_evidence for a landmark not seen yet).
  int evidence(LandmarkId id) const;
  /// T as counted (initial_evidence for a landmark not seen yet).
  double evidenceValue(LandmarkId id) const;
  const EvidenceModel& evidenceModel() const { return model_; }
  TentativeSet& tentatives() { return tentatives_; }
  const TentativeSet& tentatives() const { return tentatives_; }
  /// A new tentative feature from sighting z (noise C; `detectable` as in EvidenceModel::step).
  int startFeature(const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                   const Eigen::Vector2d& heading_lever, FeatureRules* rules,
                   double detectable = 1.0);
  /// Restarts feature `slot` from sighting z: its first sighting, or after a failed static test.
  void restartFeature(int slot, const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                      const Eigen::Vector2d& heading_lever, FeatureRules* rules,
                      double detectable = 1.0);
  void dropFeature(const AssociationContext& ctx, int slot, bool stale, FeatureRules* rules);
  void reset();

 private:
  int nearest(const LocalScan& scan, int obs, const Eigen::Vector2d& v_bar, bool use_taken) const;
  void nearestAll(LocalScan* scan, const Eigen::Vector2d& v_bar) const;
  Eigen::Vector2d meanInnovationOfUnique(const LocalScan& scan) const;
  /// The loop shared by cases 2-4: each contested landmark keeps its closest (compensated)
  /// observation; losers re-run NN against untaken landmarks; until clean.
  void resolve(LocalScan* scan, const Eigen::Vector2d& v_bar, DjnnStats* stats) const;

  DjnnPaperParams p_;
  EvidenceModel model_;
  double gate_ = 0.0;
  double wide_gate_ = 0.0;
  double tentative_gate_ = 0.0;
  double penalty_radial_ = 0.0, penalty_lateral_ = 0.0;
  std::unordered_map<LandmarkId, double> evidence_;
  TentativeSet tentatives_;
  FeatureKey next_key_ = 0;
  std::vector<FeatureKey> ended_;  // keys that ended since the last countFeatureEvidence
  std::vector<std::pair<FeatureKey, FeatureKey>> restarted_;  // (earlier run, new run)
  // Per-scan scratch.
  std::vector<int> tent_near_;
  std::vector<char> tent_hit_;
  std::vector<char> tent_withheld_;  // near a withheld sighting this scan: not missed
  std::vector<char> obs_withheld_;
  std::vector<Sighting> sightings_;
  struct TentativePair {
    double d2;
    int obs;
    int local;  ///< index into tent_near_
  };
  std::vector<TentativePair> tentative_pairs_;
  std::vector<TentativePair> tentative_wide_;
};

}  // namespace ekf_slam
