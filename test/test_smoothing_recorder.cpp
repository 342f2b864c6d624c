// SmoothingRecorder (core/smoothing/smoothing_recorder.h) on a simulated world run through
// SlamPipeline with DJNN: what it collects per scan, every landmark of the run as an unknown
// (removed ones too), covariances for the final map, and the smoothed trajectory against the truth.
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace ekf_slam {
namespace test_smoothing_recorder {

TEST(SmoothingRecorder, SmoothsARunWithItsRemovedLandmarks) {
  const sim::World world = sim::makeWorld("djnn_strong");  // 50 movers: DJNN removes some
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  SlamPipeline pipeline(readPipelineConfig(MapParameterSource(sim::pipelineParametersFor(world))),
                        djnn);
  pipeline.setSensorOffset(world.sensor.offset);
  SmoothingRecorder recorder;
  std::vector<StampedPoint> truth, filter;
  std::set<LandmarkId> created, removed;
  std::size_t reports = 0;
  sim::Simulation simulation(world, 2);
  feedSimulation(simulation, pipeline, [&](const sim::ObservationSet& set) {
    const double stamp = set.stamp + sim::kStampOffset;
    const ScanReport r = pipeline.processObservations(stamp, set.toObservations());
    recorder.add(r, pipeline);
    ++reports;
    for (std::size_t i = 0; i < r.association.decision.size(); ++i)
      if (r.association.decision[i] == Decision::kNew) created.insert(r.association.landmark[i]);
    removed.insert(r.removed.begin(), r.removed.end());
    truth.push_back({stamp, set.true_pose.head<2>()});
    filter.push_back({stamp, pipeline.pose().head<2>()});
    return true;
  });
  ASSERT_EQ(recorder.scans().size(), reports);
  EXPECT_FALSE(recorder.scans().front().linked);
  EXPECT_TRUE(recorder.scans().back().linked);
  ASSERT_FALSE(removed.empty());

  const SmoothingResult r = recorder.smooth(pipeline);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.dropped_observations, 0u);
  // Every landmark the run made, the final map's first and in its order.
  const std::vector<MapLandmark> map = pipeline.mapLandmarks();
  ASSERT_EQ(r.landmarks.size(), created.size());
  for (std::size_t k = 0; k < r.landmarks.size(); ++k) {
    if (k < map.size()) {
      EXPECT_EQ(r.landmarks[k].id, map[k].id);
      EXPECT_TRUE(r.landmark_covariances[k].allFinite());
    } else {
      EXPECT_EQ(removed.count(r.landmarks[k].id), 1u) << r.landmarks[k].id;
      EXPECT_FALSE(r.landmark_covariances[k].allFinite());
    }
  }
  // The whole run's data: the trajectory's shape far closer to the truth than the online one.
  std::vector<StampedPoint> smoothed;
  for (std::size_t i = 0; i < r.poses.size(); ++i)
    smoothed.push_back({recorder.scans()[i].stamp, r.poses[i].head<2>()});
  const double online = compareTrajectories(filter, truth).rmse_aligned;
  const double after = compareTrajectories(smoothed, truth).rmse_aligned;
  EXPECT_LT(after, 0.5 * online) << "online " << online;
}

}  // namespace test_smoothing_recorder
}  // namespace ekf_slam
