// DJNN extension "bias test" (docs/djnn.md, "Dynamic filtering of pseudo-features"): a map
// landmark whose innovations keep pointing one way follows a moving object. A discounted sum
// a = sum lambda^k G v of its world-frame innovations (lambda = 1 - 1 / bias_window) with
// covariance B = sum lambda^2k G S G^T; a^T B^-1 a > chi2(2, bias_probability) after
// bias_min_pairings pairings withdraws the pairing and removes the landmark, or, with
// bias_keep_pairings, keeps a landmark that many unbiased pairings established (a mover passed
// close by).
#pragma once

#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class BiasTest {
 public:
  struct Params {
    bool bias_test = true;
    double bias_probability = 0.999;
    double bias_window = 5.0;
    int bias_min_pairings = 3;
    int bias_keep_pairings = 0;  ///< 0: off (every biased landmark is removed)
    /// Scale the test's covariance by the innovations' measured consistency (docs/djnn.md).
    bool bias_consistency_scale = true;
  };
  void read(const ParameterReader& r);
  void configure();
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  bool on() const { return p_.bias_test; }
  void reset() {
    bias_.clear();
    scale_ = 1.0;
    scans_ = 0;
    ratios_.clear();
  }
  /// The innovations' consistency scale in use (1: as consistent as the filter claims).
  double scale() const { return scale_; }

  /// Tests the scan's pairings: a biased one is withdrawn (rejected, not a new feature) and its
  /// landmark removed (result->remove; its evidence forgotten) unless established.
  void test(const AssociationContext& ctx, LocalScan* scan, AssociationResult* result,
            DjnnPaper* paper, DjnnStats* stats);
  /// A landmark left the map.
  void forget(LandmarkId id) { bias_.erase(id); }
  /// Drops the state of landmarks no longer in the map when it could dominate (amortised).
  void sweep(const EkfSlam& ekf);

 private:
  struct Bias {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    int pairings = 0;
  };
  /// Adds the pairing of observation `obs` with landmark state index j; its statistic
  /// a^T B^-1 a, or -1 before bias_min_pairings.
  double accumulate(const AssociationContext& ctx, int obs, int j);

  Params p_;
  double gate_ = 0.0, decay_ = 0.8;
  std::unordered_map<LandmarkId, Bias> bias_;
  double scale_ = 1.0;  // median over scans of median(statistic) / median(chi2(2)), at least 1
  std::size_t scans_ = 0;
  std::vector<double> ratios_;                       // the last scans' ratios, a ring
  std::vector<double> stat_sorted_, stat_, window_;  // scratch
};

}  // namespace ekf_slam
