// Dynamic Joint Nearest Neighbour, DJNN (seed 000 section 3; ALGORITHMS.md section 4): NN
// restricted to the local region around the sensor (eq. 10), interference between pairings
// resolved with the observation compensation v_bar (eq. 6-8, cases 1-4), and an evidence counter
// T (eq. 9) that admits features seen often enough and removes landmarks missed more often than
// seen; plus dynamic filtering: a static-consistency test of tentative features and an
// innovation-bias test of landmarks (keeps slow movers out of the map).
// Parameters, defaults and the points the paper leaves open: docs/djnn.md.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/djnn/held_window.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/coverage_grid.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/sensor_model.h"

namespace ekf_slam {

class DJNN : public DataAssociation {
 public:
  /// Which interference case of seed 000 section 3 the last associate() call started in.
  enum class Case : std::uint8_t {
    kNone = 0,            ///< no association ran (empty scan)
    kNoInterference = 1,  ///< case 1: NN result accepted
    kPartial = 2,         ///< case 2: p > 0 unique pairs, k interfering
    kAllInterfere = 3,    ///< case 3: every pairing interferes (p = 0)
    kNothingPaired = 4,   ///< case 4: no observation paired
  };

  /// Counters since configure()/reset(), for tests and diagnostics.
  struct Stats {
    std::uint64_t scans = 0;              ///< associate() calls with at least one observation
    std::uint64_t cases[5] = {};          ///< indexed by Case
    std::uint64_t case4_accepted = 0;     ///< case 4, no landmark in the valid region (eq. 7)
    std::uint64_t case4_compensated = 0;  ///< case 4, a wide-gate pair (eq. 8) gave v_bar
    std::uint64_t resolution_rounds = 0;  ///< interference-resolution rounds, all cases
    std::uint64_t admitted = 0;           ///< kNew decisions
    std::uint64_t removed = 0;            ///< landmarks returned in result.remove
    std::uint64_t tentative_dropped = 0;
    std::uint64_t static_restarts = 0;      ///< tentative features restarted by the static test
    std::uint64_t biased_removed = 0;       ///< landmarks removed by the innovation-bias test
    std::uint64_t biased_kept = 0;          ///< pairings withdrawn from established landmarks
    std::uint64_t shifts_taken = 0;         ///< scans whose pairing a likelier shift replaced
    std::uint64_t shifts_ambiguous = 0;     ///< scans with pairings withdrawn as ambiguous
    std::uint64_t density_withdrawn = 0;    ///< pairings withdrawn by the density test
    std::uint64_t joint_scans = 0;          ///< loop-closure scans given the joint decision
    std::uint64_t joint_held = 0;           ///< observations the joint decision left undecided
    std::uint64_t joint_incomplete = 0;     ///< joint searches over budget (scan held)
    std::uint64_t remembered = 0;           ///< tentative features remembered at their timeout
    std::uint64_t remembered_admitted = 0;  ///< observations admitted on a remembered feature
    /// Admissions refused: the source lay within landmark_spacing of a map landmark.
    std::uint64_t spacing_refused = 0;
    std::uint64_t window_scans = 0;       ///< joint decisions weighed with held scans
    std::uint64_t held_streaks = 0;       ///< runs of held joint scans that ended
    std::uint64_t held_streak_scans = 0;  ///< scans in those runs
  };

  /// Parameters (names as read in configure(); defaults in docs/djnn.md).
  struct Params {
    /// R (sensor_range), min_range, field_of_view, fov_polygon, detection_probability P_D and
    /// clutter_density: the regions of eq. 7 / 9 / 10 and the evidence weights.
    SensorModel sensor;
    double range_margin = 3.0;  ///< d [m]
    double angle_margin = 0.1;  ///< dphi [rad]
    double individual_probability = 0.999;
    /// An unpaired observation within chi2(2, p) of a local landmark (plain or compensated) is
    /// ambiguous and rejected rather than made tentative; >= individual_probability.
    double ambiguity_probability = 0.999;
    double wide_gate_factor = 3.0;  ///< eq. 8
    int admit_evidence = 7;
    int remove_evidence = 0;
    int initial_evidence = 2;  ///< T of map landmarks DJNN has not seen yet
    int max_evidence = 0;      ///< cap on T (0: unbounded, as in the paper)
    double tentative_gate_probability = 0.95;
    double tentative_timeout = 60.0;  ///< [s] of stamp; 0 disables
    /// Where a missed feature scores r_k = -1 (eq. 9): "sensor" = range R and the field of view;
    /// "valid" = the valid region of eq. 7 (shrunk by the margins).
    std::string penalty_region = "sensor";
    /// Static-consistency test of a tentative feature (dynamic filtering of pseudo-features):
    /// the sightings must fit one static point, sum of normalised residuals about their fused
    /// position <= chi2(2 (k - 1), static_probability); else the feature restarts from the
    /// latest sighting. static_jitter [m] (isotropic std dev per sighting) stands for the pose
    /// estimate's jitter between sightings.
    bool static_test = true;
    double static_probability = 0.9;
    double static_jitter = 0.0;
    /// The static test also allows for the pose's heading error, held common to the sightings:
    /// its effect on a sighting grows with the lever from the vehicle to the point, so sightings
    /// from different distances differ by sigma_theta times the change of that lever (a camera
    /// approaching a floor marker). Position errors common to the sightings cancel and are left
    /// out, as before.
    bool static_heading = false;
    /// Tentative features follow the pose estimate's correction in each EKF update (a rigid
    /// transform from the prior pose to the posterior one), as a landmark initialised from the
    /// pose would through its correlation with it; false = they stay where they were placed.
    bool tentative_follow_pose = false;
    /// Shift test of the scan's pairings (a periodic layout, a loop closure with a large pose
    /// error): the pairing of the scan is compared by joint likelihood, with the full covariance,
    /// with the same scan shifted onto the neighbours in the gate. A shift more likely by more than
    /// shift_margin (in -2 ln of the likelihood ratio) replaces it; one within the margin makes the
    /// pairings that differ ambiguous (rejected: neither paired nor tentative). false = off.
    bool shift_test = false;
    double shift_margin = 6.0;
    /// Unmapped landmarks per m^2 where the sensor looks (0 = off). With it the scan's pairings
    /// must be likelier, jointly, than the same observations being landmarks not in the map (or
    /// clutter: density landmark_density + clutter_density): while the pose is uncertain a lone
    /// observation inside a wide gate says nothing, several that fit together do. Pairings are
    /// withdrawn, least likely first, until the rest pass; the withdrawn observations are rejected.
    double landmark_density = 0.0;
    double loop_closure_age = 0.0;  ///< [s] joint decision when a gated landmark is older; 0: off
    double joint_margin = 6.0;      ///< -2 ln of the likelihood ratio the joint best must beat
    /// Remembered sightings (0 = off): a tentative feature that times out with at least this many
    /// static sightings is kept as a remembered feature, anchored to the map landmark nearest to
    /// it at its last sighting (offset and its covariance), and the joint decision may pair an
    /// observation with it (the feature is then admitted) instead of charging "not in the map":
    /// a hole in the map is evidence, not absence. Used only with loop_closure_age > 0.
    int remembered_sightings = 0;
    /// With remembered_sightings: -2 ln charged to the joint decision's option of a live tentative
    /// feature started by a held observation (its first sighting, never decided "not in the
    /// map", may be the old landmark the closure is about); 0 = off. "Closing the loops".
    double held_birth_cost = 0.0;
    /// Least distance [m] between two landmarks of the world (0 = off; needs clutter_density > 0).
    /// In the joint decision an observation whose source lies, with probability
    /// individual_probability, within this distance of a candidate landmark cannot be another
    /// landmark not in the map: its "not in the map" is charged at the clutter density alone.
    double landmark_spacing = 0.0;
    /// With loop_closure_age: while the joint decision holds a closure, up to this many held scans
    /// are kept, carried by the odometry, and the current scan is decided on them and itself
    /// jointly (the prior counted once) instead of on itself alone; 0 = off. "Deciding a held
    /// closure on the held scans".
    int held_window_scans = 0;
    /// -2 ln margin a decision weighed with held scans must pass (0: joint_margin). The evidence
    /// of a window is larger than one scan's, but the margin is still a per-test error rate.
    double held_window_margin = 0.0;
    /// Side [m] of the cells of a coverage grid counting the scans whose sensor region covered
    /// each cell (0 = off; needs loop_closure_age and clutter_density > 0). In the joint decision
    /// an observation's "not in the map" is charged at landmark_density (1 - P_D)^n +
    /// clutter_density, n the looks at its source (capped at coverage_max_looks), averaged over
    /// the source's position uncertainty: where the sensor looked often an unmapped landmark is
    /// unlikely. "Where the sensor has looked" in docs/djnn.md.
    double coverage_cell = 0.0;
    int coverage_max_looks = 10;  ///< cap on n (successive looks are not independent)
    /// With loop_closure_age: a scan that follows held scans of a closure decides it only if its
    /// joint best implies the same pose correction (the mean world-frame offset of its paired
    /// observations' sources from their landmarks, within chi2(2, individual_probability)) as the
    /// joint best of each of the last this many held scans; else it is held too. 0 = off. "A held
    /// closure decided only on a lead that repeats".
    int held_confirmations = 0;
    /// Slowest speed [m/s] of a moving object that must be kept out of the map; 0 = off. With
    /// it, the sightings of a tentative feature are also fitted with a constant-velocity track:
    /// its velocity must pass v^T Sigma_v^-1 v <= chi2(2, static_probability) (else the feature
    /// restarts), and admission waits until Sigma_v is small enough that an object at this speed
    /// would fail that test with probability static_probability (the sightings span enough time).
    double static_min_speed = 0.0;
    /// Innovation-bias test of map landmarks: a discounted sum a = sum lambda^k G v of the world-
    /// frame innovations (lambda = 1 - 1 / bias_window) with covariance B = sum lambda^2k G S G^T;
    /// a^T B^-1 a > chi2(2, bias_probability) after bias_min_pairings pairings marks a landmark
    /// that follows a moving object: it is removed and its pairing of this scan withdrawn.
    bool bias_test = true;
    double bias_probability = 0.999;
    double bias_window = 5.0;
    int bias_min_pairings = 3;
    /// A landmark with at least this many pairings is established: when the bias test fires on
    /// it (a mover passing close by) only the pairing is withdrawn and its bias state restarted,
    /// the landmark stays. 0 = off (every biased landmark is removed).
    int bias_keep_pairings = 0;
  };

  DJNN();

  void configure(const ParameterSource& params) override;
  std::string name() const override { return "DJNN"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void landmarkAdded(int obs, LandmarkId id) override;
  void landmarkLoaded(LandmarkId id, std::uint32_t times_observed) override;
  void poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) override;
  void reset() override;
  int evidence(LandmarkId id) const override;
  std::vector<TentativeFeature> tentativeFeatures() const override;

  const Params& params() const { return p_; }
  Case lastCase() const { return last_case_; }
  const Stats& stats() const { return stats_; }
  /// v_bar (range, bearing) that decided the pairing of the last scan (zero in case 1).
  const Eigen::Vector2d& lastCompensation() const { return last_v_bar_; }

 private:
  struct Tentative {
    Eigen::Vector2d position;
    Eigen::Matrix2d cov;  ///< observation-noise part only (the pose part is added at gating)
    /// d(position) / d(heading) of the fused sightings (static_heading): the lever of the fused
    /// position, fused like it.
    Eigen::Vector2d heading_lever = Eigen::Vector2d::Zero();
    double evidence = 0.0;
    double last_seen = 0.0;
    bool alive = false;
    int sightings = 0;      ///< fused into position since the last (re)start
    double residual = 0.0;  ///< sum of normalised residuals of the sightings (static test)
    /// Constant-velocity fit of the sightings since the last (re)start (static_min_speed > 0):
    /// information matrix and vector of (position at first_seen, velocity).
    double first_seen = 0.0;
    Eigen::Matrix4d track_info = Eigen::Matrix4d::Zero();
    Eigen::Vector4d track_vec = Eigen::Vector4d::Zero();
    /// Nearest map landmark at the last sighting and the offset to it (remembered_sightings).
    LandmarkId anchor = kNoLandmark;
    Eigen::Vector2d anchor_offset = Eigen::Vector2d::Zero();
    Eigen::Matrix2d anchor_cov = Eigen::Matrix2d::Zero();
    bool held_birth = false;  ///< started by an observation the joint decision held
  };
  /// A tentative feature that timed out after enough sightings (remembered_sightings): where it
  /// was relative to its anchor landmark.
  struct Remembered {
    Eigen::Vector2d offset;
    Eigen::Matrix2d cov;
    int key;  ///< unique, for the joint decision's one-to-one rule
  };
  /// Innovation-bias state of a map landmark (bias test).
  struct Bias {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    int pairings = 0;
  };
  using CellKey = std::int64_t;
  /// An unpaired observation of this scan as a candidate feature (eq. 9).
  struct Sighting {
    Eigen::Vector2d pos;            ///< inverse model at the current pose
    Eigen::Matrix2d cov_obs;        ///< G_z R G_z^T
    Eigen::Vector2d heading_lever;  ///< d pos / d heading (column 2 of G_x)
    int slot;                       ///< tentative feature it matched, or -1
    bool eligible;
  };
  struct TentativePair {
    double d2;
    int obs;
    int local;  ///< index into tent_near_
  };

  // --- association (eq. 5-8) -----------------------------------------------------------------
  void buildCandidates(const AssociationContext& ctx);
  const AssociationContext::Individual& pair(int obs, int cand) const {
    return table_[static_cast<std::size_t>(obs) * cand_.size() + cand];
  }
  /// Normalised distance (eq. 5) of observation `obs` compensated by v_bar to candidate `cand`;
  /// *mahalanobis receives the compensated M_ij.
  double score(int obs, int cand, const Eigen::Vector2d& v_bar, double* mahalanobis) const;
  /// NN of one compensated observation among untaken candidates (gate on the compensated M).
  int nearest(int obs, const Eigen::Vector2d& v_bar, bool use_taken) const;
  void nearestAll(const Eigen::Vector2d& v_bar);
  /// Counts pairings per candidate; returns the number of contested candidates.
  int countPairings();
  Eigen::Vector2d meanInnovationOfUnique() const;
  /// The loop shared by cases 2-4: each contested landmark keeps its closest (compensated)
  /// observation; losers re-run NN against untaken landmarks; until clean.
  void resolve(const Eigen::Vector2d& v_bar);
  /// p_sensor inside the sensor region grown by `radial` [m] in range and `lateral` [m] across
  /// its edges (negative: shrunk).
  bool inRegion(const Eigen::Vector2d& p_sensor, double radial, double lateral) const {
    return p_.sensor.contains(p_sensor, radial, lateral);
  }
  /// Evidence increment r_k of a feature seen (hit) or missed in the sensor region: 2 (1 - tau)
  /// and -2 tau with tau = (P_D + P_F) / 2, P_F the chance that clutter falls into the feature's
  /// gate (position covariance C); +1 / -1 for P_D = 1 without clutter (the paper's counter).
  double evidenceStep(bool hit, const Eigen::Matrix2d& C) const;

  // --- evidence (eq. 9) ----------------------------------------------------------------------
  void updateMapEvidence(const AssociationContext& ctx, AssociationResult* result);
  /// Bias test of the landmark paired with observation `obs` (candidate `cand`); true = biased.
  bool biased(const AssociationContext& ctx, int obs, int cand);
  void handleUnpaired(const AssociationContext& ctx, AssociationResult* result);
  /// The shift test (Params::shift_test) on assign_, before the evidence is counted.
  void shiftTest(const AssociationContext& ctx);
  /// The density test (Params::landmark_density) on assign_.
  void densityTest(const AssociationContext& ctx);
  bool jointDecision(const AssociationContext& ctx);
  /// With held scans in the window: replaces the single-scan decision `d` of `problem` (over
  /// `ectx`) by the best of its hypotheses (the best and each observation's alternative) weighed
  /// with the held scans' best explanation given each (djnn_held_window.cpp).
  void heldWindowDecision(const AssociationContext& ctx, const AssociationContext& ectx,
                          const JointMlProblem& problem, JointMlDecision* d);
  /// After a joint decision: keeps the held entries `held` (indices into problem.obs) of this scan
  /// in the window, or clears it when nothing was held.
  void keepHeld(const AssociationContext& ctx, const AssociationContext& ectx,
                const JointMlProblem& problem, const std::vector<int>& held);
  /// The pose correction a joint hypothesis implies (held_confirmations, djnn_confirm.cpp).
  struct Lead {
    bool valid = false;   ///< a complete decision
    bool paired = false;  ///< it pairs an observation with a map landmark
    Eigen::Vector2d offset = Eigen::Vector2d::Zero();  ///< mean source - landmark, world frame
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();     ///< its covariance, the pose's excluded
  };
  Lead leadOf(const AssociationContext& ctx, const JointMlProblem& problem,
              const JointMlDecision& d) const;
  /// True when `lead` agrees with every held scan's lead kept in held_leads_.
  bool leadRepeats(const Lead& lead) const;
  /// Ends a streak of held joint scans: counts it in the stats, drops the kept leads.
  void endHeldStreak();
  /// Adds to the candidates the landmarks a pose error of three standard deviations could bring
  /// into view that gate with an observation (for the joint decision).
  void widenCandidates(const AssociationContext& ctx);
  /// -2 ln likelihood of pairing observation `obs` with candidate `c` (or none: -1) for every
  /// paired observation of `h`, jointly: D^2 + ln|S| of the pairs, the gate plus ln|S_i| of the
  /// closest candidate for an observation left unpaired.
  double jointCost(const AssociationContext& ctx, const std::vector<int>& h) const;
  int addTentative(const Eigen::Vector2d& pos, const Eigen::Matrix2d& cov, double stamp,
                   const Eigen::Vector2d& heading_lever);
  /// Drops a tentative feature; one that timed out (`stale`) may be remembered.
  void dropTentative(int slot, bool stale = false);
  /// -2 ln of "not in the map" for observation `obs` of the joint decision, given its gated
  /// candidates (landmark_spacing).
  /// Whether the source of `obs` lies, with probability individual_probability, within
  /// landmark_spacing of one of `landmarks` (state-order indices): that landmark or clutter,
  /// never another landmark. False with landmark_spacing 0 (djnn_spacing.cpp).
  bool withinSpacing(const AssociationContext& ctx, int obs,
                     const std::vector<int>& landmarks) const;
  double unmappedCostOf(const AssociationContext& ctx, int obs,
                        const std::vector<int>& gated) const;
  /// landmark_density times the chance that a landmark at the source of observation `obs` is
  /// not in the map given the looks there (coverage_cell; landmark_density when off).
  double unmappedDensityOf(const AssociationContext& ctx, int obs) const;
  /// Counts this scan's sensor region in the coverage grid (coverage_cell > 0).
  void recordCoverage();
  /// Anchors tentative feature `slot` to the nearest local landmark (remembered_sightings).
  void anchorTentative(const AssociationContext& ctx, int slot);
  void moveTentative(int slot, const Eigen::Vector2d& pos);
  CellKey tentativeKey(const Eigen::Vector2d& p) const;
  void queryTentatives(const Eigen::Vector2d& center, double radius, std::vector<int>* out) const;
  double bump(double evidence, double r) const;
  /// Starts the tentative feature in `slot` afresh from one sighting (position z, observation
  /// covariance C, at `stamp`): its first sighting, or the restart after a failed static test.
  void startTentative(int slot, const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                      const Eigen::Vector2d& heading_lever);
  /// Adds a sighting to the constant-velocity fit of `t` (static_min_speed > 0).
  static void addToTrack(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                         double stamp);
  /// The fit's velocity information J (inverse covariance of the velocity, position marginalised)
  /// and the velocity test statistic v^T J v; false when the velocity is not determined yet.
  static bool trackVelocity(const Tentative& t, Eigen::Matrix2d* J, double* statistic);
  /// The sightings of tentative feature `slot` span enough time for the velocity test to see an
  /// object at static_min_speed (always true when that is off).
  bool longEnough(int slot) const;

  Params p_;
  double gate_ = 0.0;
  double wide_gate_ = 0.0;
  double ambiguity_gate_ = 0.0;
  double tentative_gate_ = 0.0;
  double tentative_cell_ = 10.0;
  double penalty_radial_ = 0.0, penalty_lateral_ = 0.0;
  Chi2Table static_gate_;
  double velocity_gate_ = 0.0;         ///< chi2(2, static_probability)
  double baseline_information_ = 0.0;  ///< least velocity information for admission [s^2/m^2]
  double bias_gate_ = 0.0, bias_decay_ = 0.8;

  // Per-scan scratch, reused between calls to avoid heap churn.
  Eigen::Vector3d sensor_pose_ = Eigen::Vector3d::Zero();
  std::vector<MeasurementKind> obs_kind_;  ///< per observation of the scan
  std::vector<int> near_;                  ///< landmarksNear() result
  std::vector<int> cand_;                  ///< local region (eq. 10), state-order indices
  std::vector<char> cand_valid_;           ///< in the valid region (eq. 7)
  std::vector<AssociationContext::Individual> table_;  ///< m x |cand|
  std::vector<int> assign_;                            ///< per observation: candidate slot or -1
  std::vector<int> count_;                             ///< per candidate: observations assigned
  std::vector<char> taken_;                            ///< per candidate
  std::vector<char> gated_;  ///< per observation: passed the gate with some candidate
  std::vector<int> winner_;  ///< per candidate: closest contesting observation
  std::vector<double> winner_score_;
  std::vector<int> tent_near_;
  std::vector<char> tent_hit_;
  std::vector<Sighting> sightings_;
  std::vector<TentativePair> tentative_pairs_;

  // State kept between scans.
  std::unordered_map<LandmarkId, double> evidence_;
  std::unordered_map<LandmarkId, double> last_paired_;  ///< stamp (loop_closure_age > 0 only)
  double stamp_ = 0.0;                                  ///< of the last scan
  std::unordered_map<LandmarkId, Bias> bias_;
  std::vector<Tentative> tentative_;
  std::vector<int> free_slots_;
  std::unordered_map<CellKey, std::vector<int>> tentative_cells_;
  std::size_t tentative_sweep_ = 0;
  std::vector<double> pending_new_;  ///< per observation of the last scan: T at admission, or -1
  /// Remembered features by anchor landmark (remembered_sightings).
  std::unordered_map<LandmarkId, std::vector<Remembered>> remembered_;
  int remembered_keys_ = 0;
  CoverageGrid coverage_;           ///< looks per cell (coverage_cell > 0)
  std::vector<double> miss_table_;  ///< (1 - P_D)^n for n = 0..coverage_max_looks
  bool held_scan_ = false;          ///< the joint decision held an observation of this scan
  HeldWindow held_window_;          ///< held scans of the closure (held_window_scans)
  std::deque<Lead> held_leads_;     ///< the last held scans' joint best (held_confirmations)
  std::uint64_t held_streak_ = 0;   ///< consecutive joint scans with something held
  std::vector<char> force_new_;     ///< per observation: admitted on a remembered feature, or held

  Case last_case_ = Case::kNone;
  Eigen::Vector2d last_v_bar_ = Eigen::Vector2d::Zero();
  Stats stats_;
};

}  // namespace ekf_slam
