// The data-association plugin interface. Algorithms (NN, JCBB, DJNN, NNJCBB, Hungarian) implement
// DataAssociation; the ROS side loads them with pluginlib by name ("ekf_slam/DJNN"), the ROS-free
// tests construct them directly. Everything an algorithm needs about the current scan comes
// through AssociationContext, which also caches predictions so each algorithm file holds only its
// algorithm.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// One observation of the current scan.
struct Observation {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();      ///< (range, bearing) or (x, y), sensor frame
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();  ///< measurement noise covariance, same units
  MeasurementKind kind = MeasurementKind::kRangeBearing;
  /// Optional descriptor, e.g. the trunk diameter [m]; NaN when unknown.
  double descriptor = std::numeric_limits<double>::quiet_NaN();
};

/// What happens to one observation.
enum class Decision : std::uint8_t {
  kPaired,     ///< update the EKF with landmark `landmark`
  kNew,        ///< initialise a new landmark from it
  kTentative,  ///< kept by the associator as evidence for a feature not yet in the map
  kRejected,   ///< not a landmark (clutter, ambiguous, moving object): ignored this scan
};
const char* toString(Decision d);

struct AssociationResult {
  std::vector<Decision> decision;    ///< one per observation
  std::vector<LandmarkId> landmark;  ///< one per observation; kNoLandmark unless kPaired
  std::vector<LandmarkId> remove;    ///< map landmarks to delete (e.g. DJNN's exit rule)
  /// Observations the associator recognised as a map landmark without the pose (e.g. RRWSC's
  /// graph matching) that the filter gate then refused: evidence that the pose, not the
  /// observation, is wrong (SlamPipeline's lost rule 3, docs/relocalisation.md). Associators that
  /// cannot tell leave 0.
  int gate_refused = 0;

  void resize(std::size_t n) {
    decision.assign(n, Decision::kRejected);
    landmark.assign(n, kNoLandmark);
    remove.clear();
    gate_refused = 0;
  }
  void pair(std::size_t obs, LandmarkId id) {
    decision[obs] = Decision::kPaired;
    landmark[obs] = id;
  }
};

/// A feature the associator tracks outside the map (for display only).
struct TentativeFeature {
  Eigen::Vector2d position;
  int evidence;
};

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

  AssociationContext(const EkfSlam& ekf, const RangeBearingModel& model, const LandmarkIndex& index,
                     const std::vector<Observation>& observations, double stamp);

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

  /// State-order indices of the landmarks within `radius` of `center` (spatial index).
  std::vector<int> landmarksNear(const Eigen::Vector2d& center, double radius) const;
  /// Landmarks that can be paired with some observation: within the farthest observation's
  /// range plus `margin` of the sensor. The usual candidate set of the gated algorithms.
  std::vector<int> candidateLandmarks(double margin) const;

  const Prediction& prediction(int landmark,
                               MeasurementKind kind = MeasurementKind::kRangeBearing) const;
  /// Computes M_ij and friends; counts one candidate evaluation.
  Individual individual(int obs, int landmark) const;
  /// Where an observation would put a landmark (inverse model at the current pose).
  Eigen::Vector2d observedPosition(int obs) const;

  /// Cross-covariance block cov(v_a, v_b) of the innovations of pairs (obs_a, lm_a) and
  /// (obs_b, lm_b), through the full covariance (pose and map correlations); includes R when the
  /// two pairs share the observation.
  Eigen::Matrix2d innovationCovariance(int obs_a, int lm_a, int obs_b, int lm_b) const;
  /// Joint innovation and its covariance for a hypothesis (pairs of obs, landmark index).
  void jointInnovation(const std::vector<std::pair<int, int>>& pairs, Eigen::VectorXd* v,
                       Eigen::MatrixXd* S) const;
  /// Joint Mahalanobis distance D^2 of a hypothesis (0 for an empty one).
  double jointMahalanobis(const std::vector<std::pair<int, int>>& pairs) const;

  /// Number of individual() calls so far (tests check that cost does not grow with the map).
  std::size_t evaluations() const { return evaluations_; }

 private:
  const EkfSlam& ekf_;
  const RangeBearingModel& model_;
  const LandmarkIndex& index_;
  const std::vector<Observation>& obs_;
  double stamp_;
  // Keyed by landmark index and kind (2 index + kind) and filled on first use: a scan touches a
  // handful of landmarks, so the cache must not cost O(map) to set up. Node-based, so returned
  // references stay valid.
  mutable std::unordered_map<int, Prediction> predictions_;
  mutable std::size_t evaluations_ = 0;
};

/// The plugin interface. pluginlib needs a default constructor, so parameters come in configure().
class DataAssociation {
 public:
  virtual ~DataAssociation() = default;

  /// Reads and validates every parameter (throws ParameterError naming a bad one). Called once,
  /// before the first associate(); calling it again re-configures and resets.
  virtual void configure(const ParameterSource& params) = 0;
  /// Short name, e.g. "DJNN".
  virtual std::string name() const = 0;

  /// Decides, for every observation of the scan, paired / new / tentative / rejected, and which
  /// landmarks to remove.
  virtual AssociationResult associate(const AssociationContext& context) = 0;

  /// The pipeline initialised landmark `id` from observation `obs` of the last associate() call
  /// (after a kNew decision). Associators that keep per-landmark state hook in here.
  virtual void landmarkAdded(int /*obs*/, LandmarkId /*id*/) {}

  /// The pipeline loaded landmark `id` from a saved map, where it had been paired in
  /// `times_observed` scans. Associators with per-landmark state (evidence) initialise it here,
  /// so that a reused map is not thrown away before the data had a chance to confirm it.
  virtual void landmarkLoaded(LandmarkId /*id*/, std::uint32_t /*times_observed*/) {}

  /// The EKF update of the last associate() call moved the pose estimate from `prior` to
  /// `posterior` (x, y, heading; map frame). Associators that keep features outside the map,
  /// placed from the prior pose, can move them along (DJNN's tentative features).
  virtual void poseCorrected(const Eigen::Vector3d& /*prior*/,
                             const Eigen::Vector3d& /*posterior*/) {}

  /// Forgets all state kept between scans (tentative features, counters).
  virtual void reset() = 0;

  /// Per-landmark evidence counter, when the algorithm keeps one (else 0).
  virtual int evidence(LandmarkId /*id*/) const { return 0; }
  /// Features tracked outside the map, when the algorithm keeps any.
  virtual std::vector<TentativeFeature> tentativeFeatures() const { return {}; }
};

/// The base of every wrapper of an associator (e.g. the offline runner's problem capture): it
/// forwards every virtual above to the wrapped one, so a wrapper overrides only what it adds and
/// can never drop a hook. A virtual added to DataAssociation is forwarded here too
/// (test_plugin_forwarding counts them).
class ForwardingAssociator : public DataAssociation {
 public:
  explicit ForwardingAssociator(std::shared_ptr<DataAssociation> inner)
      : inner_(std::move(inner)) {}

  void configure(const ParameterSource& params) override { inner_->configure(params); }
  std::string name() const override { return inner_->name(); }
  AssociationResult associate(const AssociationContext& context) override {
    return inner_->associate(context);
  }
  void landmarkAdded(int obs, LandmarkId id) override { inner_->landmarkAdded(obs, id); }
  void landmarkLoaded(LandmarkId id, std::uint32_t times_observed) override {
    inner_->landmarkLoaded(id, times_observed);
  }
  void poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) override {
    inner_->poseCorrected(prior, posterior);
  }
  void reset() override { inner_->reset(); }
  int evidence(LandmarkId id) const override { return inner_->evidence(id); }
  std::vector<TentativeFeature> tentativeFeatures() const override {
    return inner_->tentativeFeatures();
  }

  const DataAssociation& inner() const { return *inner_; }

 private:
  std::shared_ptr<DataAssociation> inner_;
};

}  // namespace ekf_slam
