// A stationary vehicle before a patch of trees, its association scripted: the lost rules and
// the rollback of SlamPipeline tested without an associator's own decisions
// (test_share_lost_rule, test_lost_rollback).
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"

namespace ekf_slam {
namespace lost_scene {

constexpr int kLandmarks = 8;

// An irregular patch of trees ahead (no symmetry a relocaliser could confuse), x forward.
inline const Eigen::Vector2d kTrees[kLandmarks] = {{8.0, -1.2}, {9.5, -0.3}, {7.0, 0.4},
                                                   {11.0, 1.5}, {6.5, 2.5},  {10.0, -2.8},
                                                   {12.5, 0.9}, {8.8, 3.6}};

// Maps every observation at the first scan, then pairs the first `paired` observations with the
// landmarks they started (all of them when `paired` < 0) and rejects the others; `remove` is
// asked once.
class Scripted : public DataAssociation {
 public:
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "Scripted"; }
  AssociationResult associate(const AssociationContext& context) override {
    AssociationResult r;
    const std::size_t n = context.observations().size();
    r.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (ids_.size() < n) {
        r.decision[i] = Decision::kNew;
      } else if (paired < 0 || static_cast<int>(i) < paired) {
        r.pair(i, ids_[i]);
      }
    }
    r.remove = std::move(remove);
    remove.clear();
    return r;
  }
  void landmarkAdded(int obs, LandmarkId id) override {
    ids_.resize(std::max<std::size_t>(ids_.size(), obs + 1), kNoLandmark);
    ids_[obs] = id;
  }
  void reset() override { ids_.clear(); }
  LandmarkId id(int obs) const { return ids_[obs]; }
  int paired = -1;
  std::vector<LandmarkId> remove;

 private:
  std::vector<LandmarkId> ids_;
};

// The vehicle at the origin, seeing the trees exactly, with FGCBB as its relocaliser.
class Scene {
 public:
  explicit Scene(const PipelineConfig& config) {
    associator_ = std::make_shared<Scripted>();
    pipeline_ = std::make_unique<SlamPipeline>(config, associator_);
    pipeline_->setRelocaliser(std::make_shared<FGCBB>());
  }
  /// `scans` scans of the first `seen` trees, each pairing `paired` observations (< 0: all); true
  /// if it went lost (it stops there).
  bool run(int scans, int paired, int seen = kLandmarks) {
    associator_->paired = paired;
    for (int k = 0; k < scans; ++k) {
      t_ += 0.2;
      OdometryInput o;
      o.stamp = t_;
      pipeline_->addOdometry(o);
      std::vector<Observation> obs(seen);
      for (int i = 0; i < seen; ++i) {
        obs[i].z = Eigen::Vector2d(kTrees[i].norm(), std::atan2(kTrees[i].y(), kTrees[i].x()));
        obs[i].R = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
      }
      last_ = pipeline_->processObservations(t_, obs);
      if (last_.became_lost) return true;
    }
    return false;
  }
  /// Each landmark's mean by id.
  std::map<LandmarkId, Eigen::Vector2d> map() const {
    std::map<LandmarkId, Eigen::Vector2d> m;
    const EkfSlam& ekf = pipeline_->ekf();
    for (std::size_t k = 0; k < ekf.numLandmarks(); ++k)
      m[ekf.landmarkIds()[k]] = ekf.landmark(static_cast<int>(k));
    return m;
  }
  SlamPipeline& pipeline() { return *pipeline_; }
  Scripted& associator() { return *associator_; }
  const ScanReport& last() const { return last_; }

 private:
  double t_ = 0.0;
  ScanReport last_;
  std::shared_ptr<Scripted> associator_;
  std::unique_ptr<SlamPipeline> pipeline_;
};

}  // namespace lost_scene
}  // namespace ekf_slam
