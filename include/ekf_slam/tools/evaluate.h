// Monte Carlo evaluation of associators on the simulated worlds (ALGORITHMS.md sections 9-10;
// docs/results.md):
//
//   rosrun ekf_slam evaluate --world djnn_weak --runs 20
//       --associators ekf_slam/NN,ekf_slam/JCBB,ekf_slam/DJNN --out /tmp/eval  (one line)
//
// Every associator runs on the same seeds (run r has seed first_seed + r); each run is a fresh
// SlamPipeline fed a sim::Simulation (runSimulationOn, the same numbers ekf_slam_offline reports
// on the simulated bag of that world and seed). Runs go to a pool of --jobs threads. Writes
// DIR/results.csv (one row per run and associator), DIR/nees.csv (the Monte Carlo average NEES
// per scan) and DIR/summary.md (mean and spread per world and associator). With --relocaliser
// every run recovers from a lost pose (docs/relocalisation.md), and results.csv gains
// lost_events, relocalisations, wrong_relocalisations, recovery_scans (empty: never),
// recovery_s and pose_rmse_after_recovery_m.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/world_parameters.h"

namespace ekf_slam {

struct EvaluateOptions {
  /// World names or prefixes ending in '*' (e.g. "rrw_noise_*"), in the order given.
  std::vector<std::string> worlds;
  int runs = 20;
  /// Seed of run 0; unset: each world's default_seed.
  bool first_seed_set = false;
  std::uint64_t first_seed = 1;
  std::vector<std::string> associators = {"ekf_slam/NN", "ekf_slam/JCBB", "ekf_slam/DJNN"};
  std::string out_dir;
  /// Optional YAML: pipeline parameters at the top level, each associator's under its short
  /// name (the layout of config/simulation.yaml). Its values override the world's.
  std::string params_path;
  /// --set NAME=VALUE (a pipeline parameter), --set ALGO/NAME=VALUE (associator ALGO, e.g.
  /// DJNN), --set '*/NAME=VALUE' (every associator). Applied last.
  std::vector<std::pair<std::string, std::string>> overrides;
  /// Relocaliser plugin ("FGCBB"): lost-robot recovery in every run, scored in the recovery
  /// columns of results.csv; "": none; unset: the YAML's, else the associator's
  /// (defaultRelocaliserFor). Its parameters: its YAML section, the world's
  /// (sim::associatorParametersFor), then --set NAME/...
  std::optional<std::string> relocaliser;
  int jobs = 0;  ///< worker threads; 0 = the number of cores
  /// --odometry-correction MODE: the pipeline's odometry_correction (empty: the YAML's or none).
  std::string odometry_correction;
  bool progress = true;
  /// --oracle: DJNN also gets the truth-derived parameters (sim::oracleDjnnParameters), a
  /// comparison column. Default: the datasheet alone.
  sim::Knowledge knowledge = sim::Knowledge::kDatasheet;
};

/// One run of one associator.
struct EvaluationRow {
  std::string world;
  std::string associator;  ///< short name, e.g. DJNN
  int run = 0;             ///< 0-based
  std::uint64_t seed = 0;
  std::string odometry_correction = "none";  ///< the pipeline's mode for this run
  std::string relocaliser;                   ///< short name; empty: recovery off
  RunMetrics metrics;
  std::vector<double> nees;             ///< per scan (RunScorer::neesPerScan)
  std::vector<Eigen::Vector2d> errors;  ///< per scan (RunScorer::errorsPerScan)
};

struct Evaluation {
  EvaluateOptions options;
  std::vector<std::string> worlds;  ///< expanded names
  std::vector<EvaluationRow> rows;  ///< world-major, then associator, then run
  double wall_time_s = 0.0;
};

/// sim::expandWorldNames (names and prefixes such as "rrw_kidnap_*"); throws
/// std::invalid_argument listing the names when one matches nothing.
std::vector<std::string> expandWorldNames(const std::vector<std::string>& patterns);

/// The configuration of one world and associator ("ekf_slam/DJNN", or "truth"): the world's
/// values (sim::pipelineParametersFor, sim::associatorParametersFor, sim::extractorFor) where
/// the YAML is silent, then the options (associator, relocaliser, odometry correction, --set).
/// buildPipeline() on it gives the run's pipeline, as ekf_slam_offline does from the YAML that
/// `simulate` writes.
YamlConfiguration evaluationConfiguration(const EvaluateOptions& options, const sim::World& world,
                                          const std::string& associator);

/// One run as evaluate makes it: a pipeline from `parts` (buildPipeline of the configuration
/// above) on world + seed, scored. `on_scan` (may be empty) sees every processed scan.
RunMetrics evaluateRun(const PipelineParts& parts, const sim::World& world, std::uint64_t seed,
                       std::vector<double>* nees_per_scan = nullptr,
                       std::vector<Eigen::Vector2d>* errors_per_scan = nullptr,
                       const ScanObserver& on_scan = {});

/// Runs everything. Throws std::runtime_error / std::invalid_argument / UnknownAssociatorError /
/// ParameterError before any run starts when a name or parameter is wrong; a run that throws
/// aborts the evaluation with its world, associator and seed in the message.
Evaluation runEvaluation(const EvaluateOptions& options, std::ostream& log);

/// DIR/results.csv, DIR/nees.csv, DIR/summary.md. `command` is quoted in the summary.
void writeEvaluation(const Evaluation& e, const std::string& command);
/// The text of summary.md.
std::string summaryMarkdown(const Evaluation& e, const std::string& command);

bool parseEvaluateArguments(const std::vector<std::string>& args, EvaluateOptions* options,
                            bool* help, std::string* error);
void printEvaluateUsage(std::ostream& out);
/// The whole command; returns the exit code (0 ok, 1 run error, 2 bad arguments).
int evaluateMain(int argc, char** argv);

}  // namespace ekf_slam
