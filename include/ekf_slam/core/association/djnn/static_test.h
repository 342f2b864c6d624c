// DJNN extension "static test" (docs/djnn.md, "Dynamic filtering of pseudo-features"): a
// tentative feature's sightings must fit one static point (sum of normalised residuals about
// their fused position <= chi2(2 (k - 1), static_probability)), else it restarts from the latest
// sighting; admission waits for admit_evidence sightings of one static point. Options:
// static_heading (a heading error common to the sightings), static_min_speed (a constant-velocity
// fit of the sightings: its velocity must pass chi2(2), and admission waits until an object at that
// speed would have shown its motion), a learned speed (without static_min_speed: the same test
// and wait at the speed MoverSpeed learned, mover_speed.h), admission_velocity_test (at admission,
// the sightings' joint constant-velocity fit must show no velocity at
// admission_velocity_probability), fewer_sightings_without_movers (while the test's own failures
// show no mover, static_failure_rate.h, admission waits for the paper's evidence alone),
// waive_velocity_test_without_movers (nor is the admission velocity test asked for then),
// chance_failures_without_movers (nor does a failed test restart the feature then) and
// sightings_admit_without_movers (admit_evidence static sightings admit a feature then, whatever
// its misses). restarted_sightings: a restart hands the earlier run to the pipeline, which keeps
// the sightings that fit the landmark the feature becomes (a static point's chance failure).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/static_failure_rate.h"
#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class StaticTest {
 public:
  struct Params {
    bool static_test = true;
    double static_probability = 0.9;
    bool static_heading = false;
    double static_min_speed = 0.0;  ///< [m/s]; 0: off
    /// At admission, no velocity in the joint constant-velocity fit (docs/djnn.md).
    bool admission_velocity_test = true;
    /// Its gate, chi2(2, p): a refusal only delays the admission (the sightings are kept), so
    /// the gate is set for power against movers rather than for few refusals (docs/djnn.md).
    double admission_velocity_probability = 0.7;
    /// While the share of sightings failing this test shows no mover (StaticFailureRate), admit
    /// on the paper's evidence alone instead of after admit_evidence sightings (docs/djnn.md).
    bool fewer_sightings_without_movers = true;
    /// While it shows no mover, no admission velocity test either (docs/djnn.md).
    bool waive_velocity_test_without_movers = false;
    /// While it shows no mover, a sighting that fails the test is a static point's chance
    /// failure: fused, but left out of the test's sums, instead of restarting the feature.
    bool chance_failures_without_movers = false;
    /// While it shows no mover, admit_evidence sightings of one static point admit the feature
    /// whatever the paper's evidence lost to misses.
    bool sightings_admit_without_movers = false;
    /// A restart passes the earlier run on to the pipeline (AssociationResult::
    /// restarted_features), which applies at admission those of its sightings that fit the
    /// landmark; off, the earlier run ends with its sightings.
    bool restarted_sightings = true;
  };
  void read(const ParameterReader& r);
  /// admit_evidence: the sightings admission waits for (and the gate table's size); learning:
  /// a speed will be learned (MoverSpeed), so every feature's track is kept from its start;
  /// horizon [s]: how long the test's failures are remembered (tentative_timeout).
  void configure(int admit_evidence, bool learning, double horizon);
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  /// restarted_sightings off: the restarted runs of `result` end instead (their sightings go).
  void endRestartedRuns(AssociationResult* result) const;
  /// Forgets the learned speed and the failures (a new run).
  void reset() {
    learned_speed_ = 0.0;
    failure_rate_.reset();
  }
  /// The speed MoverSpeed learned (0: none yet), used while static_min_speed is 0.
  void useLearnedSpeed(double speed) { learned_speed_ = speed; }
  /// The slowest speed kept out of the map in use: static_min_speed, else the learned one, else
  /// 0 (no velocity test, no wait).
  double minSpeed() const;

  /// The pose covariance of this scan (static_heading reads its heading variance).
  void beginScan(const Eigen::Matrix3d& P_vv);
  /// Sightings kept per feature for the joint test.
  static constexpr int kMaxJointSightings = 12;

  /// A sighting z (noise C, heading lever) of feature t: false when t is no static point. With
  /// `ctx`, observation `obs` and pose clones of t's earlier sightings in the filter
  /// (core/pipeline/delayed_sightings.h), the joint test decides; else the recursive one.
  bool stillStatic(Tentative* t, const Eigen::Vector2d& z, const Eigen::Vector2d& heading_lever,
                   const Eigen::Matrix2d& C, double stamp, const AssociationContext* ctx = nullptr,
                   int obs = -1);
  /// Keeps observation `obs` of this scan as t's latest sighting (the joint test's history).
  void record(const AssociationContext& ctx, int obs, Tentative* t) const;
  /// The joint test's statistic: t's earlier sightings that have a pose clone and observation
  /// `obs` at the current pose, their positions from the poses' current estimates, about one
  /// static point, by generalised least squares with the poses' joint covariance (their
  /// correlations cancel the common pose error; each sighting's noise G_z R G_z^T). *dof = 2 (m -
  /// 1) for m sightings; false when fewer than two.
  bool jointStatistic(const AssociationContext& ctx, const Tentative& t, int obs, double* statistic,
                      int* dof) const;
  /// The same sightings fitted with a constant velocity, z_k = p + (t_k - t_0) v: the velocity
  /// v_hat, its information J (p marginalised) and the residual about the track (2 (m - 2) dof,
  /// m sightings); false when fewer than three.
  bool jointTrack(const AssociationContext& ctx, const Tentative& t, int obs, Eigen::Vector2d* v,
                  Eigen::Matrix2d* J, double* residual, int* m) const;
  /// Feature t (re)starts from sighting z.
  void started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
               double stamp) const;
  /// Enough static sightings, over a long enough time, for admission.
  bool admits(const Tentative& t) const;
  /// The static sightings admission waits for now: admit_evidence, or 1 (the paper's evidence
  /// decides) while fewer_sightings_without_movers and the failures rule movers out.
  int sightingsNeeded() const;
  /// sightings_admit_without_movers: while the failures rule movers out, t has admit_evidence
  /// sightings of one static point, which admits it whatever the paper's evidence.
  bool admitsOnSightings(const Tentative& t) const;
  /// admission_velocity_test: t's sightings with pose clones and observation `obs`, fitted with a
  /// constant velocity (jointTrack), show a velocity beyond chi2(2,
  /// admission_velocity_probability). False when off or when the fit is not available (fewer than
  /// three such sightings, no clones), and while waive_velocity_test_without_movers and the
  /// failures rule movers out.
  bool movingAtAdmission(const AssociationContext& ctx, const Tentative& t, int obs) const;
  /// The slowest speed at which t's sightings would have shown motion (the inverse of the
  /// admission wait); infinity when its velocity is not determined.
  double resolvedSpeed(const Tentative& t) const { return resolvedSpeed(t.track_info); }
  /// The same of a track's information (Tentative::track_info).
  double resolvedSpeed(const Eigen::Matrix4d& track_info) const;
  /// Adds a sighting (noise C, at `stamp`) to a track that started at `first_seen`; with
  /// track_vec null, to its information only (how well it resolves a velocity).
  static void addToTrack(Eigen::Matrix4d* track_info, Eigen::Vector4d* track_vec,
                         const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                         double first_seen);

 private:
  /// No mover learned and the failures' share rules movers out (StaticFailureRate).
  bool noMoversSeen() const;
  /// The track's velocity information (position marginalised).
  static Eigen::Matrix2d velocityInformation(const Eigen::Matrix4d& track_info);
  /// The least eigenvalue of the symmetric 2 x 2 J (the information along the direction the
  /// velocity is least known in).
  static double leastEigenvalue(const Eigen::Matrix2d& J);
  /// False while the track has no velocity information (one sighting, or one stamp).
  static bool determined(const Eigen::Matrix2d& J);
  /// The fit's velocity information J (inverse covariance of the velocity, position marginalised)
  /// and the velocity test statistic v^T J v; false when the velocity is not determined yet.
  static bool trackVelocity(const Tentative& t, Eigen::Matrix2d* J, double* statistic);
  /// The sightings of jointStatistic as y ~ N(A x, S): y, the Cholesky factor of S, and the
  /// time of each sighting since the first.
  struct JointSightings;
  bool jointSightings(const AssociationContext& ctx, const Tentative& t, int obs,
                      JointSightings* out) const;
  /// The velocity information that admission needs at speed v (0: none).
  double baselineInformation(double v) const;

  Params p_;
  int admit_evidence_ = 7;
  bool learning_ = false;
  Chi2Table static_gate_;
  double velocity_gate_ = 0.0;         ///< chi2(2, static_probability)
  double admission_gate_ = 0.0;        ///< chi2(2, admission_velocity_probability)
  double baseline_information_ = 0.0;  ///< least velocity information for admission [s^2/m^2]
  double learned_speed_ = 0.0;         ///< MoverSpeed's, 0 until it learned one
  double heading_var_ = 0.0;           ///< of this scan (static_heading)
  StaticFailureRate failure_rate_;
};

}  // namespace ekf_slam
