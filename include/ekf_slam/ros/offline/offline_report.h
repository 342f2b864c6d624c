// The outputs of an offline run, written after the loop: trajectory.csv, associations.csv,
// landmarks.csv, map.txt, update_shapes.csv, gps.csv, the truth files of a simulated bag,
// landmark_trace.csv and the smoothed files on request, metrics.json, map.png; and the warnings
// for every input that needed handling.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>

#include <Eigen/Core>

#include "ekf_slam/core/pipeline/input_sequencer.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/ros/offline/bag_input.h"
#include "ekf_slam/ros/offline/offline_options.h"
#include "ekf_slam/ros/offline/run_record.h"

namespace ekf_slam {

/// What the run loop measured and counted.
struct LoopStats {
  std::string associator;   ///< short names
  std::string relocaliser;  ///< empty: none
  double bag_read_s = 0.0;
  double wall_time_s = 0.0;
  double loop_cpu_s = 0.0;
  Eigen::Vector3d sensor_offset = Eigen::Vector3d::Zero();  ///< of the first sensor message used
  SequencerCounters sequencer;
  std::uint64_t invalid_stamps = 0, zero_stamps = 0, skipped_no_tf = 0, time_jumps = 0;
  bool problem_dumped = false;  ///< --dump-problem's scan was reached
};

/// Writes every output to options.out_dir; returns the run's summary (metrics_json included).
/// Throws std::runtime_error when a file cannot be written, or --dump-problem's scan was not
/// reached.
OfflineSummary writeOfflineReport(const OfflineOptions& o, const BagContents& bag,
                                  const RunRecord& record, const SlamPipeline& pipeline,
                                  const LoopStats& loop, std::ostream& log);

}  // namespace ekf_slam
