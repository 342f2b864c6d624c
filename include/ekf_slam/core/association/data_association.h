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

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/observation.h"

namespace ekf_slam {

/// What happens to one observation.
enum class Decision : std::uint8_t {
  kPaired,     ///< update the EKF with landmark `landmark`
  kNew,        ///< initialise a new landmark from it
  kTentative,  ///< kept by the associator as evidence for a feature not yet in the map
  kRejected,   ///< not a landmark (clutter, ambiguous, moving object): ignored this scan
};
const char* toString(Decision d);

/// An associator's name for one feature it tracks outside the map (AssociationResult::feature).
using FeatureKey = std::int64_t;
constexpr FeatureKey kNoFeature = -1;

struct AssociationResult {
  std::vector<Decision> decision;    ///< one per observation
  std::vector<LandmarkId> landmark;  ///< one per observation; kNoLandmark unless kPaired
  std::vector<LandmarkId> remove;    ///< map landmarks to delete (e.g. DJNN's exit rule)
  /// One per observation: for kTentative, the feature it is a sighting of; for kNew, the feature
  /// it admits; for kPaired, a feature found to be that landmark (DJNN's held sightings), else
  /// kNoFeature (none, or the associator does not say). The pipeline keeps a feature's sightings
  /// against clones of their poses and applies them to the landmark when the feature is admitted
  /// or joins it (core/pipeline/delayed_sightings.h); a feature's key must change when its earlier
  /// sightings stop counting (e.g. DJNN's static test restarts it).
  std::vector<FeatureKey> feature;
  /// Features no longer tracked (dropped, restarted or admitted): their sightings are let go.
  std::vector<FeatureKey> ended_features;
  /// Features still tracked that lie out of the sensor's reach, so that the vehicle must drive
  /// back before it can sight them again (DJNN: farther from the sensor than its range plus
  /// range_margin, found by its sweep over the tentative features). With release_out_of_reach the
  /// pipeline lets the sighting of such a feature seen once go, and the pose clone held only for
  /// it, rather than carry it in the state until the feature ends.
  std::vector<FeatureKey> out_of_reach_features;
  /// (earlier run, new run): a feature restarted because its sightings were not one static point
  /// (DJNN's static test), whose earlier sightings may still be the same object's (a static
  /// point's chance failure). The pipeline keeps them with the new run and, when it is admitted,
  /// applies those that fit the landmark it became; they go when the new run ends.
  std::vector<std::pair<FeatureKey, FeatureKey>> restarted_features;
  /// Observations the associator recognised as a map landmark without the pose (e.g. RRWSC's
  /// graph matching) that the filter gate then refused: evidence that the pose, not the
  /// observation, is wrong (SlamPipeline's lost rule 3, docs/relocalisation.md). Associators that
  /// cannot tell leave 0.
  int gate_refused = 0;
  /// Something the user should know about the configuration, said once (e.g. DJNN found that the
  /// sensor misses landmarks while no detection_probability was set); the shells log it.
  std::string notice;

  void resize(std::size_t n) {
    decision.assign(n, Decision::kRejected);
    landmark.assign(n, kNoLandmark);
    feature.assign(n, kNoFeature);
    remove.clear();
    ended_features.clear();
    out_of_reach_features.clear();
    restarted_features.clear();
    gate_refused = 0;
    notice.clear();
  }
  void pair(std::size_t obs, LandmarkId id) {
    decision[obs] = Decision::kPaired;
    landmark[obs] = id;
  }
};

/// One scan processed while lost, as a landmark mapped from the lost scans saw it
/// (DataAssociation::landmarkFromLostScans): seen in it or not, and where it lay in the scan's
/// sensor frame.
struct LostLook {
  bool seen = false;
  Eigen::Vector2d in_sensor = Eigen::Vector2d::Zero();
};

/// A feature the associator tracks outside the map (for display only).
struct TentativeFeature {
  Eigen::Vector2d position;
  int evidence;
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

  /// At a fix, the pipeline mapped landmark `id` (covariance `cov`) from the scans processed
  /// while lost (docs/relocalisation.md); `looks` holds every such scan, oldest first. False: the
  /// associator's own rules would have removed it by now, and the pipeline removes it. The
  /// default takes it as a landmark seen that often (landmarkLoaded) and keeps it.
  virtual bool landmarkFromLostScans(LandmarkId id, const Eigen::Matrix2d& /*cov*/,
                                     const std::vector<LostLook>& looks) {
    std::uint32_t seen = 0;
    for (const LostLook& l : looks) seen += l.seen;
    landmarkLoaded(id, seen);
    return true;
  }

  /// At a fix, landmark `id` of the map before, still recent when the lost scans began (made
  /// within lost_recent_scans of them), was near those scans; `looks` holds the ones it was near,
  /// oldest first. False: the associator's rules would have removed it had the scans been
  /// tracked, and the pipeline removes it. The default keeps it.
  virtual bool landmarkOverLostScans(LandmarkId /*id*/, const Eigen::Matrix2d& /*cov*/,
                                     const std::vector<LostLook>& /*looks*/) {
    return true;
  }

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
  bool landmarkFromLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                             const std::vector<LostLook>& looks) override {
    return inner_->landmarkFromLostScans(id, cov, looks);
  }
  bool landmarkOverLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                             const std::vector<LostLook>& looks) override {
    return inner_->landmarkOverLostScans(id, cov, looks);
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
