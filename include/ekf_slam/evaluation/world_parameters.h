// The parameters a simulated world is run with (evaluate, and the YAML `simulate` writes beside
// its bag): the pipeline's, each plugin's, and the feature extractor a laser world needs.
#pragma once

#include <map>
#include <string>

#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace sim {

/// Pipeline parameters (the names of docs/parameters.md, values as text) that match a world:
/// initial pose = the world's start pose, twist-mode noise = twistNoiseFor(world) (a world with
/// wheel factors, `aekf`: its exact speed and steering noise, no wheel-factor random walk), R =
/// the world's observation noise, observation range covering the sensor (a large finite value
/// for whole-map worlds), min range 0.
std::map<std::string, std::string> pipelineParametersFor(const World& world);
/// The simulator's own noise as pipeline parameters, where pipelineParametersFor gives the
/// datasheet's bound: speed and steering-angle noise of each control step on the wheelbase
/// (twist_steering_wheelbase), the range and bearing noise. The known answer of noise
/// calibration (docs/calibration.md). A pose_delta world: the observation noise only.
std::map<std::string, std::string> trueNoiseParametersFor(const World& world);
/// readPipelineConfig(pipelineParametersFor(world)).
PipelineConfig pipelineConfigFor(const World& world);

/// What a world's configuration may be computed from.
enum class Knowledge {
  /// What a user knows: the sensor's datasheet (range limits, field of view, noise, a nominal
  /// detection probability) and the vehicle. The default everywhere (issue 31).
  kDatasheet,
  /// ... plus what only the simulator knows (oracleDjnnParameters): `evaluate --oracle`, a
  /// comparison column, never a default.
  kOracle,
};

/// Parameters of plugin `short_name` ("DJNN", "NN", "FGCBB", ...) that depend on the world's
/// sensor: DJNN's sensor_range and field_of_view (the local region, eq. 10: for a whole-map
/// sensor a range that covers the site), min_range, nominal detection_probability, fov_polygon,
/// range_margin; the relocalisers' sensor_range; empty for plugins without such parameters.
std::map<std::string, std::string> associatorParametersFor(
    const World& world, const std::string& short_name, Knowledge knowledge = Knowledge::kDatasheet);

/// The DJNN parameters computed from the simulator's truth that earlier rounds configured per
/// world (landmark_density, landmark_spacing, clutter_density, static_min_speed from the true
/// landmarks, clutter and movers, and the switches set by the world's class). Only for
/// Knowledge::kOracle; empty for a sensor that detects every landmark.
std::map<std::string, std::string> oracleDjnnParameters(const World& world);

/// Landmarks per m^2 of the ground the sensor's region covers along the world's route: the
/// landmarks inside the cells (side `cell` [m]) whose centre one of the true sensor poses of a run
/// (seed 1) saw, over the area of those cells inside the world's area (area_min..area_max). This
/// is what DJNN's `landmark_density` means ("unmapped landmarks per m^2 where the sensor looks"):
/// a corridor world holds its markers in a fraction of its bounding box. 0 for a world without
/// views. The cell is at least the sensor's covering range / 100 (a bounded cost per view).
double coveredLandmarkDensity(const World& world, double cell = 0.25);

/// The feature extractor a laser world's scans need (sim::laserWorld): its plugin's short name
/// and parameters (docs/feature_extraction.md); an empty name for the point-observation worlds.
struct ExtractorSetup {
  std::string name;
  std::map<std::string, std::string> parameters;
};
ExtractorSetup extractorFor(const World& world);

}  // namespace sim
}  // namespace ekf_slam
