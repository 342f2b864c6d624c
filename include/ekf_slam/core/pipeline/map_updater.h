// The mapping step of a tracked scan: the associator's decisions on the predicted state, made
// usable whatever it returned, then applied: one batch EKF update with every pairing, the new
// landmarks from the updated pose, the removals, the landmark book-keeping.
#pragma once

#include <cstddef>
#include <vector>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/feature_extraction/scan_occlusion.h"
#include "ekf_slam/core/filter/filter_backend.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/delayed_sightings.h"
#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

class MapUpdater {
 public:
  MapUpdater(const PipelineConfig& config, FilterBackend& filter, LandmarkIndex& index,
             const RangeBearingModel& model, LandmarkBook& book, DelayedSightings& delayed,
             PipelineCounters& counters)
      : config_(config),
        filter_(filter),
        index_(index),
        model_(model),
        book_(book),
        delayed_(delayed),
        counters_(counters) {}

  /// The associator's decisions for report->observations on the predicted state, sanitised
  /// (report->association, association_s, invalid_decisions). `occlusion`: what the observations'
  /// scan hid (null without a scan).
  void associate(DataAssociation& associator, double stamp, ScanReport* report,
                 const ScanOcclusion* occlusion = nullptr);
  /// The update with the paired observations and `carried` (pairings of older scans carried into
  /// this one), then the new landmarks and their earlier sightings, then the removals
  /// (report->nis, update_ok, delayed_sightings, removed, update_s; kNew entries get the new
  /// landmark's id), then this scan's tentative sightings kept. In localization mode nothing is
  /// added or removed (counted).
  void apply(DataAssociation& associator, const std::vector<Pairing>& carried, ScanReport* report);
  /// Removes these landmarks (a kidnap's recent ones), counted as discarded.
  void discard(const std::vector<LandmarkId>& ids, ScanReport* report);

 private:
  /// Makes a result usable whatever the associator returned; returns the number of fixes.
  int sanitise(std::size_t n, AssociationResult* result) const;

  const PipelineConfig& config_;
  FilterBackend& filter_;
  LandmarkIndex& index_;
  const RangeBearingModel& model_;
  LandmarkBook& book_;
  DelayedSightings& delayed_;
  PipelineCounters& counters_;
  std::vector<Pairing> pairings_;  // per-scan workspace
};

}  // namespace ekf_slam
