// Every SlamPipeline parameter, read in one place. The node reads them over a NodeHandle
// (RosParameterSource), the offline runner from YAML (YamlParameterSource): same names, same
// defaults (PipelineConfig's), same validation. Names and meanings: docs/parameters.md.
#pragma once

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"

namespace ekf_slam {

/// Reads and validates every pipeline parameter; unset ones keep PipelineConfig's default.
/// Throws ParameterError naming the (first) bad parameter.
PipelineConfig readPipelineConfig(const ParameterSource& params);

}  // namespace ekf_slam
