// EKF-SLAM state: vehicle pose plus 2D point landmarks, dense covariance. ROS-free (Eigen only).
//
// State layout: [x, y, yaw, c_1 .. c_k, m_0x, m_0y, m_1x, m_1y, ..., clones]. The k <= 2
// odometry correction states (AEKF, odometry_correction.h; k = 0 by default) sit between the pose
// and the map, so landmark k occupies rows stateRow(k) = 3 + k + 2 index. Landmarks carry stable
// ids that survive removals; their slot in the state vector (index) may change when another
// landmark is removed. The observation model never involves the correction states: the associators
// see the pose, the landmarks and their cross-covariances exactly as without them.
//
// Pose clones (stochastic cloning, as in the MSCKF) follow the map: copies of the pose at an
// earlier scan, 3 rows each, so that an observation kept back at that scan can still be applied
// against the pose it was taken from (core/pipeline/delayed_sightings.h). They do not move in
// predict() and change only through their correlations; removing one is its exact
// marginalisation. None exist unless addClone() is called.
#pragma once

#include <cstdint>
#include <map>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/odometry_correction.h"
#include "ekf_slam/core/filter/symmetric_rank_update.h"

namespace ekf_slam {

using LandmarkId = std::int64_t;
constexpr LandmarkId kNoLandmark = -1;
/// A pose clone's stable id (EkfSlam::addClone).
using CloneId = std::int64_t;
constexpr CloneId kNoClone = -1;

/// One observation paired with a map landmark, for EkfSlam::update.
struct Pairing {
  LandmarkId id;
  Eigen::Vector2d z;  ///< (range, bearing) or (x, y) in the sensor frame, as `kind` says
  Eigen::Matrix2d R;  ///< measurement noise
  MeasurementKind kind = MeasurementKind::kRangeBearing;
  /// The pose z was taken from: the current one (kNoClone) or an earlier scan's clone.
  CloneId clone = kNoClone;
};

/// Where the filter evaluates its Jacobians (docs/consistency.md).
enum class Linearisation : std::uint8_t {
  kStandard = 0,  ///< at the current estimate
  /// First-estimates Jacobian EKF (Huang, Mourikis, Roumeliotis 2008): each landmark's H at its
  /// first estimate (its initial value) and the predicted pose; the propagation's heading column
  /// from the propagated positions (new prior minus the previous prior), not from the updated one.
  /// The Jacobians then keep the global rotation unobservable, as it truly is.
  kFirstEstimate = 1,
  /// The right-invariant EKF (Barrau & Bonnabel 2015, "An EKF-SLAM algorithm with consistency
  /// properties"): the error of every position is taken in the frame the heading error rotates
  /// (x = R(e_yaw) x_hat + e_x for the pose and the landmarks; a clone's position with its own
  /// heading). In those coordinates the odometry's transition is the identity and H has no
  /// heading column, so the global rotation stays unobservable whatever the estimate. P is kept
  /// in the standard coordinates: the Jacobians are the standard ones at the current estimate,
  /// the correction is applied through the group's exponential, and after each update P is
  /// re-expressed at the corrected estimate (P <- M P M^T, M = I + J dx e_yaw^T over the
  /// positions that follow the heading).
  kInvariant = 2,
};

/// Work done by EkfSlam::update, counted over the filter's life (kept over reset()).
struct UpdateStats {
  std::uint64_t updates = 0;  ///< batch updates applied
  /// Flops of the update's arithmetic: the rank-d downdate of P (N^2 d with N the state size and
  /// d = 2 x pairings), P H^T (10 N d), the triangular solve (N d^2) and the correction (2 N d).
  double flops = 0.0;
  double rank_flops = 0.0;  ///< of those, the rank downdates
  /// Sums of N and d weighted by each update's rank flops: divided by rank_flops, the state size
  /// and dimension at which the run does its rank updates (the size to benchmark the floor at).
  double weighted_n = 0.0, weighted_d = 0.0;
  /// Updates per shape (N, d), only after EkfSlam::recordUpdateShapes(true) (a new shape
  /// allocates): the run's exact sizes, to replay its rank downdates alone (bench_rank_update
  /// --replay, docs/benchmarks_vp.md).
  std::map<std::pair<int, int>, std::uint64_t> shapes;
};

class EkfSlam {
 public:
  EkfSlam();

  /// Drops every landmark and clone and sets the pose and its covariance, and the odometry
  /// correction states (none by default; uncorrelated with the pose). Ids restart at 0.
  void reset(const Eigen::Vector3d& pose = Eigen::Vector3d::Zero(),
             const Eigen::Matrix3d& pose_cov = Eigen::Matrix3d::Zero(),
             const CorrectionPrior& correction = CorrectionPrior());

  // --- read access --------------------------------------------------------------------------
  const Eigen::VectorXd& mean() const { return x_; }
  /// P, complete (a view of the top-left corner of storage with spare capacity): hold it as
  /// `auto` or ConstMatrixView, not as `const Eigen::MatrixXd&`, which would copy it. Valid until
  /// the next call that changes the state. The update writes only the lower triangle; the first
  /// call after it copies the lower triangle onto the upper one (O(n^2)): per-scan readers that
  /// need only some blocks use storedCovariance() or the block accessors below.
  ConstMatrixView covariance() const {
    if (upper_stale_) mirrorLower();
    return storedCovariance();
  }
  /// P as stored, not brought up to date: current are the lower triangle, the vehicle rows
  /// (pose and correction states: rows 0 .. 2 + k, every column) and each landmark's 2 x 2
  /// block; the rest of the upper triangle only after covariance().
  ConstMatrixView storedCovariance() const {
    return ConstMatrixView(store_.data(), dim_, dim_, Eigen::OuterStride<>(store_.rows()));
  }
  /// cov(x_a.., x_b..) for the 2-row blocks at state rows a and b, read from the current part.
  Eigen::Matrix2d blockCovariance(int row_a, int row_b) const {
    const ConstMatrixView P = storedCovariance();
    return row_a >= row_b ? Eigen::Matrix2d(P.block<2, 2>(row_a, row_b))
                          : Eigen::Matrix2d(P.block<2, 2>(row_b, row_a).transpose());
  }
  /// Rows and columns of storage reserved for P (grows by half when full).
  Eigen::Index covarianceCapacity() const { return store_.rows(); }
  Eigen::Vector3d pose() const { return x_.head<3>(); }
  Eigen::Matrix3d poseCovariance() const { return storedCovariance().topLeftCorner<3, 3>(); }

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
  /// Rows of the vehicle and the map: the clones start here.
  int mapEnd() const { return 3 + k_ + 2 * static_cast<int>(ids_.size()); }
  Eigen::Vector2d landmark(int index) const { return x_.segment<2>(stateRow(index)); }
  Eigen::Matrix2d landmarkCovariance(int index) const {
    return storedCovariance().block<2, 2>(stateRow(index), stateRow(index));
  }
  const UpdateStats& updateStats() const { return stats_; }
  /// Count the updates per shape in updateStats().shapes (off: the update allocates nothing).
  void recordUpdateShapes(bool on) { record_shapes_ = on; }

  /// Jacobians at the current estimate (default) or at the first estimates. Kept over reset().
  void setLinearisation(Linearisation l) { linearisation_ = l; }
  Linearisation linearisation() const { return linearisation_; }
  /// Second-order terms of range-bearing observations (EKF2: RangeBearingModel::
  /// rangeBearingSecondOrder in update(), polarSecondOrder in addLandmark()). Kept over reset().
  void setSecondOrderObservations(bool on) { second_order_ = on; }
  bool secondOrderObservations() const { return second_order_; }
  /// With second-order observations on and a range-bearing z of landmark `index`: what to add to
  /// its first-order prediction (`mean`) and to R (`extra`), from the current pose and landmark
  /// covariance; false (nothing to add) otherwise. The associators' gates use it too, so that
  /// they and the update agree on S.
  bool secondOrderTerms(int index, const RangeBearingModel& model, MeasurementKind kind,
                        Eigen::Vector2d* mean, Eigen::Matrix2d* extra) const {
    return secondOrderTerms(index, 0, model, kind, mean, extra);
  }
  /// The same seen from the pose at state row `pose_row` (0, or a clone's row).
  bool secondOrderTerms(int index, int pose_row, const RangeBearingModel& model,
                        MeasurementKind kind, Eigen::Vector2d* mean, Eigen::Matrix2d* extra) const;
  /// The landmark's first estimate: its value when added, inserted or set (setState).
  const Eigen::Vector2d& firstEstimate(int index) const { return first_[index]; }
  /// The position the pose was last predicted to (the prior: before any update since).
  const Eigen::Vector2d& priorPosition() const { return prior_position_; }

  // --- filter steps -------------------------------------------------------------------------
  /// Prediction from a motion model step: pose <- step.pose,
  /// P_vv <- F P_vv F^T + Q, P_vm <- F P_vm. O(n): the map block is untouched. With k correction
  /// states the vehicle block is [pose, c] and its transition [F Fc; 0 I] (noise Q, Qvc, Qc).
  /// Returns false (and leaves the state unchanged) when the step is not finite or its number of
  /// correction states is not k.
  /// F is [I a; 0 1] for every motion model, a = J (new position - old position), J the 90 deg
  /// rotation; with Linearisation::kFirstEstimate the old position is the prior (priorPosition()).
  bool predict(const MotionStep& step);

  /// Batch update with every pairing of one scan: x += K v, P -= K S K^T (written to the lower
  /// triangle; see covariance()), S factorised with Cholesky. No heap allocation once the
  /// workspaces have grown to the largest map so far. Returns false (and leaves the state
  /// unchanged) when S is not positive definite, a pairing names an unknown id, anything is not
  /// finite or a correction state's variance would not stay positive. Correction states pushed past
  /// their bounds are clamped (counted). Optionally returns the NIS v^T S^-1 v.
  /// H at the current pose and each landmark's estimate, or with kFirstEstimate its first one.
  /// With kInvariant the correction moves the positions through the group's exponential and P is
  /// re-expressed at the corrected estimate (an O(n^2) rank-2 step, plus O(n) per clone).
  bool update(const std::vector<Pairing>& pairings, const RangeBearingModel& model,
              double* nis = nullptr);

  /// The innovation v and its covariance S = H P H^T + R of one pairing (from its clone's pose when
  /// it names one), H at the current estimate; nothing changes. False when the landmark or the
  /// clone is unknown or anything is not finite. It reads three blocks of P: its cost does not
  /// grow with the map (finding the clone is linear in the clones, at most max_pose_clones).
  bool innovation(const Pairing& pairing, const RangeBearingModel& model, Eigen::Vector2d* v,
                  Eigen::Matrix2d* S) const;

  /// Initialises a landmark from observation z with the inverse observation model and both of
  /// its Jacobians. O(n) arithmetic (plus, when the storage is full, one copy of P into storage
  /// half as large again). Returns its new id, or kNoLandmark (state unchanged) when z, R or the
  /// result is not finite.
  /// With kFirstEstimate the pose Jacobian's heading column is taken from the prior position.
  LandmarkId addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                         const RangeBearingModel& model,
                         MeasurementKind kind = MeasurementKind::kRangeBearing);

  /// Inserts a landmark with a known mean and covariance, uncorrelated with the rest (used to
  /// load a saved map). Uses `id` when given and free, else the next id. Returns the id.
  LandmarkId insertLandmark(const Eigen::Vector2d& position, const Eigen::Matrix2d& cov,
                            LandmarkId id = kNoLandmark);

  /// Replaces the whole state (mean 3 + k + 2n with the current k, covariance, n ids, all
  /// distinct and >= 0; no clones), e.g. to replay a recorded association problem. Throws
  /// std::invalid_argument on inconsistent sizes.
  void setState(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                const std::vector<LandmarkId>& ids);

  // --- pose clones -------------------------------------------------------------------------
  /// Appends a copy of the current pose (mean, covariance and every cross-covariance): O(n).
  /// `tag` names it for findClone (the pipeline uses the scan's stamp).
  CloneId addClone(double tag = 0.0);
  /// The newest clone with this tag, or kNoClone.
  CloneId findClone(double tag) const;
  /// Marginalises a clone out (deletes its rows and columns). False if the id is unknown.
  bool removeClone(CloneId id);
  void removeAllClones();
  std::size_t numClones() const { return clones_.size(); }
  /// Clone ids in state order.
  const std::vector<CloneId>& cloneIds() const { return clones_; }
  /// Row of the clone's x, or -1 when the id is unknown.
  int cloneRow(CloneId id) const;
  Eigen::Vector3d clonePose(CloneId id) const;

  /// The pose becomes the clone's (mean, covariance, every cross-covariance) and the clone is
  /// removed: the current pose is marginalised out, e.g. after the pose was carried elsewhere to
  /// process older scans. O(n). False if the id is unknown.
  bool restorePose(CloneId id);

  /// Moves the pose estimate without touching any covariance: an unmodelled jump (a kidnap).
  void setPose(const Eigen::Vector3d& pose) {
    x_.head<3>() = pose;
    x_(2) = wrapAngle(x_(2));
    prior_position_ = x_.head<2>();
  }

  /// Replaces the pose and its covariance and zeroes the pose/map cross-covariance (the map is
  /// untouched): the pose becomes independent of the map, e.g. before re-deriving it from a
  /// relocalisation's pairings. O(n).
  void replacePose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& pose_cov);

  /// Deletes a landmark's rows and columns. Returns false if the id is unknown.
  bool removeLandmark(LandmarkId id);

 private:
  // Runs the steps on a part of the state and brings the rest up to date itself
  // (core/filter/compressed_ekf.h): it reads and writes the storage directly.
  friend class CompressedEkf;

  bool predictAugmented(const MotionStep& step);
  /// One pairing as update() takes it: the state rows of its landmark and of its pose (the
  /// current one, or its clone's), H's pose and landmark blocks (at the first estimates when
  /// `first`), R with the second-order terms, and the innovation from the current estimate.
  /// False when the landmark or the clone is unknown or anything is not finite.
  bool linearise(const Pairing& p, const RangeBearingModel& model, bool first, int* row,
                 int* pose_row, Matrix23d* Hv, Eigen::Matrix2d* Hm, Eigen::Matrix2d* R,
                 Eigen::Vector2d* v) const;
  /// kInvariant: x <- exp(xi) x with xi the correction dx in invariant coordinates; each
  /// position's change is written to `moved` (zero elsewhere).
  void retractInvariant(const Eigen::Ref<const Eigen::VectorXd>& dx, Eigen::VectorXd* moved);
  /// kInvariant: P <- M (P - W W^T) M^T, M = I + sum_b (J moved_b) e_b^T, b the pose's heading
  /// (for the pose's and the landmarks' positions) and each clone's (for its own). The terms are
  /// found before the downdate (d0_, v0_ for the pose, columns for the clones) ...
  void invariantTerms(const Eigen::Ref<const Eigen::MatrixXd>& W, const Eigen::VectorXd& moved);
  /// ... and the clones' are applied after it, to the lower triangle.
  void applyInvariantCloneTerms(const Eigen::VectorXd& moved);
  /// step.F, or with kFirstEstimate its heading column from the prior position.
  Eigen::Matrix3d transition(const MotionStep& step) const;
  MatrixView P() {
    return MatrixView(store_.data(), dim_, dim_, Eigen::OuterStride<>(store_.rows()));
  }
  /// Makes room for P of size n (keeping its contents), growing the storage geometrically so
  /// that adding landmarks one by one copies P O(log n) times, not n times.
  void reserveCovariance(Eigen::Index n);
  /// Copies the lower triangle onto the upper one (the part the update leaves stale).
  void mirrorLower() const;
  /// Inserts `count` zero rows and columns before row `at` (the rows from `at` move down):
  /// O(n (n - at)).
  void openRows(Eigen::Index at, Eigen::Index count);
  /// Deletes rows and columns [at, at + count): O(n (n - at)).
  void closeRows(Eigen::Index at, Eigen::Index count);
  /// Adds a landmark at the end of the map (before the clones) with mean m, covariance Pll and
  /// cross-covariance `cross` (2 x n in the current layout).
  LandmarkId appendLandmark(const Eigen::Vector2d& m, const Eigen::Matrix2d& Pll,
                            const Eigen::MatrixXd& cross, const Eigen::Vector2d& first);
  /// The next id for a landmark just placed at the end of the map, with its first estimate.
  LandmarkId appendId(const Eigen::Vector2d& first);
  /// Makes the upper half of each landmark's and clone's diagonal block current.
  void mirrorDiagonalBlocks();

  Eigen::VectorXd x_;
  // P is the top-left dim_ x dim_ corner of store_. Mutable: covariance() completes the upper
  // triangle on demand (upper_stale_ after an update).
  mutable Eigen::MatrixXd store_;
  Eigen::Index dim_ = 0;
  mutable bool upper_stale_ = false;
  std::vector<LandmarkId> ids_;
  std::unordered_map<LandmarkId, int> index_of_;
  LandmarkId next_id_ = 0;
  std::vector<CloneId> clones_;  // in state order, after the map
  std::vector<double> clone_tags_;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> clone_first_;
  CloneId next_clone_ = 0;
  int k_ = 0;  // correction states
  Eigen::Vector2d c_lower_ = Eigen::Vector2d::Zero(), c_upper_ = Eigen::Vector2d::Zero();
  std::uint64_t clamps_ = 0, refusals_ = 0;

  UpdateStats stats_;
  bool record_shapes_ = false;

  Linearisation linearisation_ = Linearisation::kStandard;
  bool second_order_ = false;
  // First estimates in state order (kept in every mode: switching needs them), and the position
  // of the last prediction (or reset / setPose / replacePose / setState).
  std::vector<Eigen::Vector2d, Eigen::aligned_allocator<Eigen::Vector2d>> first_;
  Eigen::Vector2d prior_position_ = Eigen::Vector2d::Zero();

  // Update workspaces, grown only when too small: no heap allocation per scan. Views over them:
  // P H^T then W = P H^T L^-T (N x d), S then its Cholesky factor (d x d), the innovation then
  // L^-1 v (d), the state correction (N), W copied in the rank downdate's tile order (N x d).
  std::vector<double> pht_, s_, v_, dx_, packed_w_, inv_a_, inv_b_;
  Eigen::VectorXd moved_, heading_col_, d0_, v0_;  // kInvariant's re-expression
  Eigen::MatrixXd clone_cols_, clone_v_, clone_d_;
  std::vector<int> rows_, pose_rows_;
  std::vector<Matrix23d> hv_;
  std::vector<Eigen::Matrix2d, Eigen::aligned_allocator<Eigen::Matrix2d>> hm_;
  std::vector<Eigen::Matrix2d, Eigen::aligned_allocator<Eigen::Matrix2d>> r_;  // R (+ EKF2)
};

}  // namespace ekf_slam
