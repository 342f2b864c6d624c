// EKF-SLAM state: vehicle pose plus 2D point landmarks, dense covariance. ROS-free (Eigen only).
//
// State layout: [x, y, yaw, c_1 .. c_k, m_0x, m_0y, m_1x, m_1y, ...]. The k <= 2 odometry
// correction states (AEKF, odometry_correction.h; k = 0 by default) sit between the pose and the
// map, so landmark k occupies rows stateRow(k) = 3 + k + 2 index. Landmarks carry stable ids that
// survive removals; their slot in the state vector (index) may change when another landmark is
// removed. The observation model never involves the correction states: the associators see the
// pose, the landmarks and their cross-covariances exactly as without them.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/angles.h"
#include "ekf_slam/core/motion_models.h"
#include "ekf_slam/core/observation_model.h"
#include "ekf_slam/core/odometry_correction.h"

namespace ekf_slam {

using LandmarkId = std::int64_t;
constexpr LandmarkId kNoLandmark = -1;

/// One observation paired with a map landmark, for EkfSlam::update.
struct Pairing {
  LandmarkId id;
  Eigen::Vector2d z;  ///< (range, bearing) or (x, y) in the sensor frame, as `kind` says
  Eigen::Matrix2d R;  ///< measurement noise
  MeasurementKind kind = MeasurementKind::kRangeBearing;
};

class EkfSlam {
 public:
  EkfSlam();

  /// Drops every landmark and sets the pose and its covariance, and the odometry correction
  /// states (none by default; uncorrelated with the pose). Ids restart at 0.
  void reset(const Eigen::Vector3d& pose = Eigen::Vector3d::Zero(),
             const Eigen::Matrix3d& pose_cov = Eigen::Matrix3d::Zero(),
             const CorrectionPrior& correction = CorrectionPrior());

  // --- read access --------------------------------------------------------------------------
  const Eigen::VectorXd& mean() const { return x_; }
  const Eigen::MatrixXd& covariance() const { return P_; }
  Eigen::Vector3d pose() const { return x_.head<3>(); }
  Eigen::Matrix3d poseCovariance() const { return P_.topLeftCorner<3, 3>(); }

  /// Number of odometry correction states k (0: the plain EKF).
  int correctionDim() const { return k_; }
  /// Their mean and covariance (zero-padded to 2).
  Eigen::Vector2d correction() const;
  Eigen::Matrix2d correctionCovariance() const;
  /// Updates that pushed a correction state past its bounds (clamped back), and updates refused
  /// because a correction variance would have become non-positive. Kept over reset().
  std::uint64_t correctionClamps() const { return clamps_; }
  std::uint64_t correctionRefusals() const { return refusals_; }

  std::size_t numLandmarks() const { return ids_.size(); }
  /// Ids in state order: landmark k occupies rows stateRow(k), stateRow(k) + 1.
  const std::vector<LandmarkId>& landmarkIds() const { return ids_; }
  /// State-order index of a landmark, or -1 when the id is not in the map.
  int indexOf(LandmarkId id) const;
  bool contains(LandmarkId id) const { return indexOf(id) >= 0; }
  /// Row of the landmark's x in the state vector (3 + k + 2 * index).
  int stateRow(int index) const { return 3 + k_ + 2 * index; }
  Eigen::Vector2d landmark(int index) const { return x_.segment<2>(stateRow(index)); }
  Eigen::Matrix2d landmarkCovariance(int index) const {
    return P_.block<2, 2>(stateRow(index), stateRow(index));
  }

  // --- filter steps -------------------------------------------------------------------------
  /// Prediction from a motion model step: pose <- step.pose,
  /// P_vv <- F P_vv F^T + Q, P_vm <- F P_vm. O(n): the map block is untouched. With k correction
  /// states the vehicle block is [pose, c] and its transition [F Fc; 0 I] (noise Q, Qvc, Qc).
  /// Returns false (and leaves the state unchanged) when the step is not finite or its number of
  /// correction states is not k.
  bool predict(const MotionStep& step);

  /// Batch update with every pairing of one scan: x += K v, P -= K S K^T (symmetrised), S
  /// factorised with Cholesky. Returns false (and leaves the state unchanged) when S is not
  /// positive definite, a pairing names an unknown id, anything is not finite or a correction
  /// state's variance would not stay positive. Correction states pushed past their bounds are
  /// clamped (counted). Optionally returns the NIS v^T S^-1 v.
  bool update(const std::vector<Pairing>& pairings, const RangeBearingModel& model,
              double* nis = nullptr);

  /// Initialises a landmark from observation z with the inverse observation model and both of
  /// its Jacobians. O(n) arithmetic (plus the copy of P into its grown storage). Returns its new
  /// id, or kNoLandmark (state unchanged) when z, R or the result is not finite.
  LandmarkId addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                         const RangeBearingModel& model,
                         MeasurementKind kind = MeasurementKind::kRangeBearing);

  /// Inserts a landmark with a known mean and covariance, uncorrelated with the rest (used to
  /// load a saved map). Uses `id` when given and free, else the next id. Returns the id.
  LandmarkId insertLandmark(const Eigen::Vector2d& position, const Eigen::Matrix2d& cov,
                            LandmarkId id = kNoLandmark);

  /// Replaces the whole state (mean 3 + k + 2n with the current k, covariance, n ids, all
  /// distinct and >= 0), e.g. to replay a recorded association problem. Throws
  /// std::invalid_argument on inconsistent sizes.
  void setState(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                const std::vector<LandmarkId>& ids);

  /// Moves the pose estimate without touching any covariance: an unmodelled jump (a kidnap).
  void setPose(const Eigen::Vector3d& pose) {
    x_.head<3>() = pose;
    x_(2) = wrapAngle(x_(2));
  }

  /// Replaces the pose and its covariance and zeroes the pose/map cross-covariance (the map is
  /// untouched): the pose becomes independent of the map, e.g. before re-deriving it from a
  /// relocalisation's pairings. O(n).
  void replacePose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& pose_cov);

  /// Deletes a landmark's rows and columns. Returns false if the id is unknown.
  bool removeLandmark(LandmarkId id);

 private:
  bool predictAugmented(const MotionStep& step);

  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  std::vector<LandmarkId> ids_;
  std::unordered_map<LandmarkId, int> index_of_;
  LandmarkId next_id_ = 0;
  int k_ = 0;  // correction states
  Eigen::Vector2d c_lower_ = Eigen::Vector2d::Zero(), c_upper_ = Eigen::Vector2d::Zero();
  std::uint64_t clamps_ = 0, refusals_ = 0;

  // Update workspaces, kept between calls to avoid reallocating them each scan.
  Eigen::MatrixXd pht_;  // P H^T, then P H^T L^-T
  Eigen::MatrixXd s_;    // S, then its Cholesky factor
  Eigen::VectorXd v_;    // innovation, then L^-1 v
  Eigen::VectorXd dx_;   // state correction
  std::vector<int> rows_;
  std::vector<Matrix23d> hv_;
  std::vector<Eigen::Matrix2d, Eigen::aligned_allocator<Eigen::Matrix2d>> hm_;
};

}  // namespace ekf_slam
