// What an associator sees of one scan: the filter, the observation model, the spatial index and
// the observations, read-only, with the predictions and compatibilities cached per landmark, so
// that each algorithm file holds only its algorithm.
#pragma once

#include <cstddef>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/feature_extraction/scan_occlusion.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

/// Everything an associator sees for one scan, read-only, with cached helpers. Landmarks are
/// referred to by their state-order index (EkfSlam::landmark(index)) while associating; results
/// are reported by id (landmarkId(index)).
class AssociationContext {
 public:
  /// Predicted observation of one landmark and its Jacobians (cached per landmark and kind).
  struct Prediction {
    Eigen::Vector2d z_hat;
    Matrix23d H_pose;
    Eigen::Matrix2d H_landmark;
    /// Second-order terms' covariance, added to S (EkfSlam::secondOrderTerms; zero when off).
    Eigen::Matrix2d extra = Eigen::Matrix2d::Zero();
  };
  /// Individual compatibility of observation i with landmark j.
  struct Individual {
    Eigen::Vector2d v;  ///< innovation z_i - h_j (bearing wrapped)
    Eigen::Matrix2d S;  ///< H P H^T + R_i
    Eigen::Matrix2d S_inv;
    double mahalanobis;  ///< v^T S^-1 v  (M_ij)
    double log_det_S;    ///< ln |S_ij|
  };

  /// `occlusion`: what the scan the observations came from hid (null: no scan, e.g. a camera's
  /// point observations; nothing is known hidden then).
  AssociationContext(const EkfSlam& ekf, const RangeBearingModel& model, const LandmarkIndex& index,
                     const std::vector<Observation>& observations, double stamp,
                     const ScanOcclusion* occlusion = nullptr);

  const EkfSlam& ekf() const { return ekf_; }
  const RangeBearingModel& model() const { return model_; }
  const std::vector<Observation>& observations() const { return obs_; }
  std::size_t numObservations() const { return obs_.size(); }
  double stamp() const { return stamp_; }
  Eigen::Vector3d robotPose() const { return ekf_.pose(); }
  Eigen::Vector3d sensorPose() const { return model_.sensorPose(ekf_.pose()); }
  LandmarkId landmarkId(int index) const { return ekf_.landmarkIds()[index]; }
  std::size_t numLandmarks() const { return ekf_.numLandmarks(); }
  /// The spatial index (e.g. for a context over other observations of the same scan).
  const LandmarkIndex& landmarkIndex() const { return index_; }
  /// The scan's occlusion, or null when the observations came without a scan.
  const ScanOcclusion* occlusion() const { return occlusion_; }

  /// State-order indices of the landmarks within `radius` of `center` (spatial index).
  std::vector<int> landmarksNear(const Eigen::Vector2d& center, double radius) const;
  /// Landmarks that can be paired with some observation: within the farthest observation's
  /// range plus `margin` of the sensor. The usual candidate set of the gated algorithms.
  std::vector<int> candidateLandmarks(double margin) const;

  const Prediction& prediction(int landmark,
                               MeasurementKind kind = MeasurementKind::kRangeBearing) const;
  /// Covariance of a landmark's predicted range and bearing, H P H^T (no measurement noise).
  Eigen::Matrix2d predictedCovariance(int landmark) const;
  /// Computes M_ij and friends; counts one candidate evaluation.
  Individual individual(int obs, int landmark) const;
  /// Where an observation would put a landmark (inverse model at the current pose).
  Eigen::Vector2d observedPosition(int obs) const;
  /// Where a return z (noise R) taken from pose xv puts a point, with G_pose = d/d xv and `cov`
  /// the point's covariance from R. With the filter's second-order terms on, the banana of a
  /// far return seen with coarse bearings: the mean pulled in by range sigma_b^2 / 2 and its
  /// spread along the beam (RangeBearingModel::polarSecondOrder), which first order misses.
  Eigen::Vector2d sightingPosition(const Eigen::Vector3d& xv, const Eigen::Vector2d& z,
                                   const Eigen::Matrix2d& R, MeasurementKind kind,
                                   Matrix23d* G_pose, Eigen::Matrix2d* cov) const;

  /// Cross-covariance block cov(v_a, v_b) of the innovations of pairs (obs_a, lm_a) and
  /// (obs_b, lm_b), through the full covariance (pose and map correlations); includes R when the
  /// two pairs share the observation.
  Eigen::Matrix2d innovationCovariance(int obs_a, int lm_a, int obs_b, int lm_b) const;
  /// innovationCovariance of each of the first `count` pairs of `pairs` with the pair (obs, lm),
  /// stacked in `out` (2 count x 2): the second pair's share is computed once.
  void innovationCovariances(const std::vector<std::pair<int, int>>& pairs, std::size_t count,
                             int obs, int lm, Eigen::Ref<Eigen::MatrixXd> out) const;
  /// Joint innovation and its covariance for a hypothesis (pairs of obs, landmark index).
  void jointInnovation(const std::vector<std::pair<int, int>>& pairs, Eigen::VectorXd* v,
                       Eigen::MatrixXd* S) const;
  /// Joint Mahalanobis distance D^2 of a hypothesis (0 for an empty one).
  double jointMahalanobis(const std::vector<std::pair<int, int>>& pairs) const;

  /// Number of individual() calls so far (tests check that cost does not grow with the map).
  std::size_t evaluations() const { return evaluations_; }

 private:
  /// The second pair's share of innovationCovariance: P [H_pose H_landmark]^T over the pose
  /// rows and its landmark's rows.
  struct PairShare {
    const Prediction* pred;
    int row;                           ///< its landmark's state row
    Eigen::Matrix<double, 3, 2> PvHb;  ///< P_pose,: H_b^T
  };
  PairShare shareOf(int obs, int lm) const;
  Eigen::Matrix2d innovationCovariance(int obs_a, int lm_a, int obs_b, int lm_b,
                                       const PairShare& b) const;

  const EkfSlam& ekf_;
  const RangeBearingModel& model_;
  const LandmarkIndex& index_;
  const std::vector<Observation>& obs_;
  double stamp_;
  const ScanOcclusion* occlusion_;
  // Keyed by landmark index and kind (2 index + kind) and filled on first use: a scan touches a
  // handful of landmarks, so the cache must not cost O(map) to set up. Node-based, so returned
  // references stay valid.
  mutable std::unordered_map<int, Prediction> predictions_;
  mutable std::size_t evaluations_ = 0;
};

}  // namespace ekf_slam
