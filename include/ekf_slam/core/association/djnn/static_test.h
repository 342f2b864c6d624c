// DJNN extension "static test" (docs/djnn.md, "Dynamic filtering of pseudo-features"): a
// tentative feature's sightings must fit one static point (sum of normalised residuals about
// their fused position <= chi2(2 (k - 1), static_probability)), else it restarts from the latest
// sighting; admission waits for admit_evidence sightings of one static point. Options:
// static_jitter (pose jitter per sighting), static_heading (a heading error common to the
// sightings), static_min_speed (a constant-velocity fit of the sightings: its velocity must pass
// chi2(2), and admission waits until an object at that speed would have shown its motion).
#pragma once

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class StaticTest {
 public:
  struct Params {
    bool static_test = true;
    double static_probability = 0.9;
    double static_jitter = 0.0;  ///< [m] isotropic std dev per sighting
    bool static_heading = false;
    double static_min_speed = 0.0;  ///< [m/s]; 0: off
  };
  void read(const ParameterReader& r);
  /// admit_evidence: the sightings admission waits for (and the gate table's size).
  void configure(int admit_evidence);
  const Params& params() const { return p_; }

  /// The pose covariance of this scan (static_heading reads its heading variance).
  void beginScan(const Eigen::Matrix3d& P_vv);
  /// Noise added to each sighting (static_jitter).
  Eigen::Matrix2d sightingNoise() const;
  /// Sightings kept per feature for the joint test.
  static constexpr int kMaxJointSightings = 12;

  /// A sighting z (noise C, heading lever) of feature t: false when t is no static point. With
  /// `ctx`, observation `obs` and pose clones of t's earlier sightings in the filter
  /// (core/pipeline/delayed_sightings.h), the joint test decides; else the recursive one.
  bool stillStatic(Tentative* t, const Eigen::Vector2d& z, const Eigen::Vector2d& heading_lever,
                   const Eigen::Matrix2d& C, double stamp, const AssociationContext* ctx = nullptr,
                   int obs = -1) const;
  /// Keeps observation `obs` of this scan as t's latest sighting (the joint test's history).
  void record(const AssociationContext& ctx, int obs, Tentative* t) const;
  /// The joint test's statistic: t's earlier sightings that have a pose clone and observation
  /// `obs` at the current pose, their positions from the poses' current estimates, about one
  /// static point, by generalised least squares with the poses' joint covariance (their
  /// correlations cancel the common pose error; each sighting's noise G_z R G_z^T plus
  /// static_jitter). *dof = 2 (m - 1) for m sightings; false when fewer than two.
  bool jointStatistic(const AssociationContext& ctx, const Tentative& t, int obs, double* statistic,
                      int* dof) const;
  /// Feature t (re)starts from sighting z.
  void started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
               double stamp) const;
  /// Enough static sightings, over a long enough time, for admission.
  bool admits(const Tentative& t) const;

 private:
  /// Adds a sighting to the constant-velocity fit of `t`.
  static void addToTrack(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                         double stamp);
  /// The fit's velocity information J (inverse covariance of the velocity, position marginalised)
  /// and the velocity test statistic v^T J v; false when the velocity is not determined yet.
  static bool trackVelocity(const Tentative& t, Eigen::Matrix2d* J, double* statistic);

  Params p_;
  int admit_evidence_ = 7;
  Chi2Table static_gate_;
  double velocity_gate_ = 0.0;         ///< chi2(2, static_probability)
  double baseline_information_ = 0.0;  ///< least velocity information for admission [s^2/m^2]
  double heading_var_ = 0.0;           ///< of this scan (static_heading)
};

}  // namespace ekf_slam
