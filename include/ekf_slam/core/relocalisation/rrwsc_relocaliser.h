// RRW&SC relocaliser (seed 004; ALGORITHMS.md section 7): the scan is matched against the map as
// two graphs by the same RrwscMatcher as the ekf_slam/RRWSC associator; pose hypotheses come from
// pairs of the best-scoring correspondences, each is verified by the observations it explains,
// the best is refined by weighted least squares, and a distinct runner-up that explains nearly
// as many observations makes the answer kAmbiguous. Parameters: docs/association.md, "RRWSC
// relocaliser".
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/graph_matching/rrwsc_matcher.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

class RRWSCRelocaliser : public Relocaliser {
 public:
  struct Params {
    RrwscParams matching;
    int min_inliers = 5;                ///< observations a pose must explain
    double inlier_probability = 0.999;  ///< residual gate chi2(2, p) of an explained observation
    /// Std dev added to every residual while a two-point hypothesis is scored (its pose is only
    /// as good as two noisy points) [m].
    double hypothesis_sigma = 1.0;
    int seed_candidates = 24;  ///< best-scoring correspondences that seed hypotheses
    /// A distinct runner-up explaining >= ambiguity_ratio x the best's observations: ambiguous.
    double ambiguity_ratio = 0.8;
    double distinct_distance = 2.0;  ///< poses this far apart [m] or
    double distinct_angle = 0.1;     ///< this far apart in heading [rad] are distinct
    double search_margin = 10.0;     ///< with a prior: landmarks within max range + 3 sigma +
                                     ///< margin of the prior's sensor position take part [m]
  };

  void configure(const ParameterSource& params) override;
  std::string name() const override { return "RRWSC"; }
  void setMap(const std::vector<MapLandmark>& map) override;
  RelocalisationResult relocalise(const std::vector<Observation>& observations,
                                  const Eigen::Vector3d& sensor_offset,
                                  const PosePrior* prior) override;

  const Params& params() const { return p_; }

 private:
  /// A sensor pose and the observations it explains.
  struct Hypothesis {
    Eigen::Vector3d sensor = Eigen::Vector3d::Zero();
    std::vector<int> landmark;  ///< per observation: local map index or -1
    int inliers = 0;
    double cost = 0.0;  ///< sum of the inliers' squared normalised residuals
  };

  /// Explains each observation by its nearest local landmark within the gate (residual
  /// covariance inflated by `extra_var`).
  void score(const Eigen::Vector3d& sensor, double extra_var, Hypothesis* h) const;
  /// Weighted least squares of the sensor pose on the hypothesis' pairs, then re-scored; a few
  /// rounds. Fills *cov with the sensor pose covariance.
  void refine(Hypothesis* h, Eigen::Matrix3d* cov) const;
  /// Information matrix and gradient of the pairs' squared normalised residuals at `sensor`.
  void information(const Hypothesis& h, const Eigen::Vector3d& sensor, Eigen::Matrix3d* info,
                   Eigen::Vector3d* grad) const;
  bool distinct(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;

  Params p_;
  double gate_ = 13.815510557964274;
  std::vector<MapLandmark> map_;
  RrwscMatcher matcher_;
  MatchInput input_;
  std::vector<int> local_;  ///< local map index -> map_ index
  std::vector<int> match_;
};

}  // namespace ekf_slam
