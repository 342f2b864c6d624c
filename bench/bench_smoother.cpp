// The batch smoother's time per solve (docs/smoothing.md, docs/benchmarks.md) on real pipeline
// output: each world run once through SlamPipeline with DJNN (outside the timed loop), then
// SmoothingRecorder::smooth timed, with the final map's marginal covariances and without. Counters:
// the problem's size (scan poses, landmarks, observation residuals) and Gauss-Newton iterations.
//   bench_smoother [--benchmark_filter=fiducials] [--benchmark_min_time=2]
#include <map>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace {

using namespace ekf_slam;

// A world's run, kept for the timed loop.
struct Run {
  std::unique_ptr<SlamPipeline> pipeline;
  SmoothingRecorder recorder;
};

Run& runOf(const std::string& name) {
  static std::map<std::string, Run> runs;
  Run& run = runs[name];
  if (run.pipeline) return run;
  const sim::World world = sim::makeWorld(name);
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  run.pipeline = std::make_unique<SlamPipeline>(
      readPipelineConfig(MapParameterSource(sim::pipelineParametersFor(world))), djnn);
  run.pipeline->setSensorOffset(world.sensor.offset);
  sim::Simulation simulation(world, 1);
  feedSimulation(simulation, *run.pipeline, [&run](const sim::ObservationSet& set) {
    run.recorder.add(
        run.pipeline->processObservations(set.stamp + sim::kStampOffset, set.toObservations()),
        *run.pipeline);
    return true;
  });
  return run;
}

// covariances: the final map's marginals too (as --smooth computes them), or none.
void smooth(benchmark::State& state, const std::string& world, bool covariances) {
  Run& run = runOf(world);
  SmootherParams params;
  params.landmark_covariances = covariances ? -1 : 0;
  SmoothingResult r;
  for (auto _ : state) {
    r = run.recorder.smooth(*run.pipeline, params);
    benchmark::DoNotOptimize(r.final_cost);
  }
  if (!r.ok) state.SkipWithError(r.error.c_str());
  state.counters["poses"] = static_cast<double>(r.poses.size());
  state.counters["landmarks"] = static_cast<double>(r.landmarks.size());
  state.counters["final_map"] = static_cast<double>(run.pipeline->mapLandmarks().size());
  state.counters["observations"] = static_cast<double>(r.observations);
  state.counters["iterations"] = r.iterations;
}

}  // namespace

int main(int argc, char** argv) {
  for (const char* world : {"tiny", "djnn_weak", "djnn_strong", "fiducials", "rrw_noise_1"})
    for (const bool covariances : {true, false})
      benchmark::RegisterBenchmark(
          (std::string("smooth/") + world + (covariances ? "" : "/no_covariances")).c_str(), smooth,
          world, covariances)
          ->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
