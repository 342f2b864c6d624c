// The evaluate tool: arguments, world patterns, parallel runs equal to serial ones, output files,
// errors before any run.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/ros/plugin_loader.h"
#include "ekf_slam/tools/evaluate.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_evaluate {

namespace fs = std::filesystem;
using test_files::readFile;
using test_files::TempDir;

bool parse(std::vector<std::string> args, EvaluateOptions* o, std::string* error) {
  bool help = false;
  return parseEvaluateArguments(args, o, &help, error);
}

TEST(EvaluateArguments, ParsesEverything) {
  EvaluateOptions o;
  std::string error;
  ASSERT_TRUE(parse(
      {"--world", "djnn_weak,hybrid", "--runs", "5", "--associators", "NN,DJNN", "--out", "/tmp/x",
       "--seed", "3", "--jobs", "1", "--set", "DJNN/individual_probability=0.999", "--no-progress"},
      &o, &error))
      << error;
  EXPECT_EQ(o.worlds, (std::vector<std::string>{"djnn_weak", "hybrid"}));
  EXPECT_EQ(o.runs, 5);
  EXPECT_EQ(o.associators, (std::vector<std::string>{"NN", "DJNN"}));
  EXPECT_TRUE(o.first_seed_set);
  EXPECT_EQ(o.first_seed, 3u);
  EXPECT_EQ(o.jobs, 1);
  ASSERT_EQ(o.overrides.size(), 1u);
  EXPECT_EQ(o.overrides[0].first, "DJNN/individual_probability");
  EXPECT_EQ(o.overrides[0].second, "0.999");
  EXPECT_FALSE(o.progress);
}

// Recovery is on unless --relocaliser "" (issue 34); the relocaliser's section gets the world's
// values whether it is named or the default.
TEST(EvaluateArguments, RelocaliserDefaultAndOff) {
  EvaluateOptions o;
  std::string error;
  ASSERT_TRUE(parse({"--world", "tiny", "--out", "/tmp/x"}, &o, &error)) << error;
  EXPECT_FALSE(o.relocaliser.has_value());
  const sim::World w = sim::makeWorld("rrw_kidnap_1");
  const PipelineParts on =
      buildPipeline(evaluationConfiguration(o, w, "ekf_slam/DJNN"), PluginlibFactory());
  EXPECT_EQ(on.relocaliser_name, "ekf_slam/FGCBB");
  EXPECT_EQ(relocaliserName(evaluationConfiguration(o, w, "ekf_slam/RRWSC")), "ekf_slam/RRWSC");
  ASSERT_TRUE(parse({"--world", "tiny", "--out", "/tmp/x", "--relocaliser", ""}, &o, &error));
  ASSERT_TRUE(o.relocaliser.has_value());
  EXPECT_EQ(
      buildPipeline(evaluationConfiguration(o, w, "ekf_slam/DJNN"), PluginlibFactory()).relocaliser,
      nullptr);
}

TEST(EvaluateArguments, RejectsBadOnes) {
  EvaluateOptions o;
  std::string error;
  EXPECT_FALSE(parse({"--out", "/tmp/x"}, &o, &error));
  EXPECT_NE(error.find("--world"), std::string::npos);
  EXPECT_FALSE(parse({"--world", "tiny", "--out", "/tmp/x", "--runs", "0"}, &o, &error));
  EXPECT_NE(error.find("--runs"), std::string::npos);
  EXPECT_FALSE(parse({"--world", "tiny", "--out", "/tmp/x", "--set", "novalue"}, &o, &error));
  EXPECT_FALSE(parse({"--world", "tiny", "--out", "/tmp/x", "--frobnicate"}, &o, &error));
  EXPECT_NE(error.find("--frobnicate"), std::string::npos);
}

TEST(EvaluateWorlds, ExpandsPrefixesAndListsNamesOnError) {
  const auto noise = expandWorldNames({"rrw_noise_*"});
  ASSERT_EQ(noise.size(), 10u);
  EXPECT_EQ(noise.front(), "rrw_noise_1");
  EXPECT_EQ(expandWorldNames({"tiny", "tiny"}).size(), 1u);
  try {
    expandWorldNames({"djnn_wek"});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("djnn_weak"), std::string::npos) << e.what();
  }
}

EvaluateOptions tinyOptions(const std::string& out) {
  EvaluateOptions o;
  o.worlds = {"tiny"};
  o.runs = 2;
  o.associators = {"ekf_slam/NN", "DJNN"};
  o.out_dir = out;
  o.jobs = 2;
  o.progress = false;
  return o;
}

// Two threads run the four runs; each must equal a serial run of the same world and seed.
TEST(Evaluate, ParallelRunsEqualSerialRunsAndFilesAreWritten) {
  const TempDir tmp("evaluate");
  const std::string dir = tmp.path().string();
  std::ostringstream log;
  const Evaluation e = runEvaluation(tinyOptions(dir), log);
  ASSERT_EQ(e.rows.size(), 4u);
  EXPECT_EQ(e.rows[0].associator, "NN");
  EXPECT_EQ(e.rows[2].associator, "DJNN");
  const sim::World w = sim::makeWorld("tiny");
  EXPECT_EQ(e.rows[0].seed, w.default_seed);
  EXPECT_EQ(e.rows[1].seed, w.default_seed + 1);
  EXPECT_EQ(e.rows[2].seed, w.default_seed);  // same seeds for every associator
  for (const EvaluationRow* r : {&e.rows[2], &e.rows[3]}) {
    auto djnn = std::make_shared<DJNN>();
    djnn->configure(MapParameterSource(sim::associatorParametersFor(w, "DJNN")));
    const RunMetrics serial = runSimulation(w, r->seed, sim::pipelineConfigFor(w), djnn);
    EXPECT_EQ(r->metrics.counts.tp, serial.counts.tp);
    EXPECT_EQ(r->metrics.counts.fp, serial.counts.fp);
    EXPECT_EQ(r->metrics.counts.tn, serial.counts.tn);
    EXPECT_EQ(r->metrics.map.landmarks, serial.map.landmarks);
    EXPECT_DOUBLE_EQ(r->metrics.pose_rmse_m, serial.pose_rmse_m);
    EXPECT_GT(r->metrics.counts.accuracy(), 0.9);
  }

  writeEvaluation(e, "evaluate --world tiny");
  const std::string csv = readFile(dir + "/results.csv");
  EXPECT_EQ(csv.rfind("world,associator,run,seed,accuracy,precision,recall,f1,", 0), 0u);
  for (const char* column :
       {"landmarks", "true_landmarks_seen", "spurious_landmarks", "pose_rmse_m", "anees",
        "association_us_mean", "pose_ate_aligned_m", "map_rmse_aligned_m", "landmarks_created",
        "landmark_precision", "landmark_recall", "pairing_coverage", "recovery_scans_map",
        "error_before_kidnap_map_m"}) {
    EXPECT_NE(csv.find(std::string(",") + column + ","), std::string::npos) << column;
  }
  EXPECT_NE(csv.find(",wrong_relocalisations_map,sightings_used\n"), std::string::npos);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);
  const std::string md = readFile(dir + "/summary.md");
  EXPECT_NE(md.find("## tiny"), std::string::npos);
  EXPECT_NE(md.find("| DJNN |"), std::string::npos);
  EXPECT_NE(md.find("| NN |"), std::string::npos);
  EXPECT_NE(md.find("| associator | ATE aligned [m] |"), std::string::npos);
  // Aligned metrics never exceed the unaligned ones; landmark-level scores are filled in.
  for (const EvaluationRow& r : e.rows) {
    EXPECT_LE(r.metrics.pose_ate_aligned_m, r.metrics.pose_rmse_m + 1e-12);
    EXPECT_GT(r.metrics.map.pairing_coverage, 0.5);
    EXPECT_GE(r.metrics.map.landmarks_created, r.metrics.map.landmarks);
  }
  EXPECT_NE(readFile(dir + "/nees.csv").find("tiny,DJNN,"), std::string::npos);
}

TEST(Evaluate, OverridesReachTheAssociator) {
  // A narrow gate misses true returns; a value out of range fails before running.
  EvaluateOptions o = tinyOptions("/nonexistent");
  o.associators = {"DJNN"};
  o.runs = 1;
  std::ostringstream log;
  const RunMetrics base = runEvaluation(o, log).rows[0].metrics;
  o.overrides = {{"*/individual_probability", "0.5"}, {"DJNN/ambiguity_probability", "0.5"}};
  const RunMetrics narrow = runEvaluation(o, log).rows[0].metrics;
  EXPECT_LT(narrow.counts.recall(), base.counts.recall());
  EXPECT_GT(narrow.counts.fn, base.counts.fn);
  o.overrides = {{"DJNN/sensor_range", "-1"}};
  EXPECT_THROW(runEvaluation(o, log), ParameterError);
}

// --odometry-correction reaches the pipeline; 'truth' is the true association; results.csv
// carries the final correction estimates and the world's true values.
TEST(Evaluate, OdometryCorrectionAndTrueAssociations) {
  EvaluateOptions o;
  std::string error;
  ASSERT_TRUE(parse({"--world", "aekf", "--out", "/tmp/x", "--odometry-correction", "wheel_factors",
                     "--associators", "truth"},
                    &o, &error))
      << error;
  EXPECT_EQ(o.odometry_correction, "wheel_factors");
  const TempDir tmp("evaluate_aekf");
  o.out_dir = tmp.path().string();
  o.runs = 1;
  o.progress = false;
  std::ostringstream log;
  const Evaluation e = runEvaluation(o, log);
  ASSERT_EQ(e.rows.size(), 1u);
  const RunMetrics& m = e.rows[0].metrics;
  EXPECT_EQ(e.rows[0].associator, "truth");
  EXPECT_EQ(e.rows[0].odometry_correction, "wheel_factors");
  EXPECT_DOUBLE_EQ(m.counts.accuracy(), 1.0);
  ASSERT_EQ(m.correction_names.size(), 2u);
  // The simulated factors 1.03 / 1.05, within 3 of the filter's std devs.
  EXPECT_NEAR(m.correction(0), 1.03, 3.0 * m.correction_sigma(0));
  EXPECT_NEAR(m.correction(1), 1.05, 3.0 * m.correction_sigma(1));
  writeEvaluation(e, "evaluate --world aekf");
  const std::string csv = readFile(o.out_dir + "/results.csv");
  EXPECT_NE(csv.find(",wheel_factors,left_factor,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",1.03,right_factor,"), std::string::npos) << csv;
  EXPECT_NE(readFile(o.out_dir + "/nees.csv").find("position_rmse_m"), std::string::npos);
  EXPECT_NE(readFile(o.out_dir + "/summary.md").find("truth 1.0300"), std::string::npos);
}

// Issue 31: the paper's DJNN (seed 000 as published) stays a named configuration,
// config/djnn_paper.yaml, and evaluate builds exactly that algorithm from it.
TEST(Evaluate, PaperPresetIsThePublishedDjnn) {
  EvaluateOptions o;
  o.params_path = std::string(EKF_SLAM_SOURCE_DIR) + "/config/djnn_paper.yaml";
  const sim::World world = sim::makeWorld("djnn_strong");
  const PipelineParts parts =
      buildPipeline(evaluationConfiguration(o, world, "ekf_slam/DJNN"), PluginlibFactory());
  EXPECT_FALSE(parts.config.delayed_sightings);
  EXPECT_EQ(parts.config.linearisation(), Linearisation::kStandard);
  const auto djnn = std::dynamic_pointer_cast<DJNN>(parts.associator);
  ASSERT_TRUE(djnn);
  const DJNN::Params& p = djnn->params();
  EXPECT_EQ(p.paper.admit_evidence, 2);
  EXPECT_EQ(p.paper.individual_probability, 0.95);
  EXPECT_EQ(p.ambiguity.ambiguity_probability, 0.95);
  EXPECT_FALSE(p.static_test.static_test);
  EXPECT_FALSE(p.bias.bias_test);
  EXPECT_FALSE(p.follow_pose.tentative_follow_pose);
  EXPECT_EQ(p.density.landmark_density, 0.0);
  EXPECT_FALSE(p.density.estimate_landmark_density);
  EXPECT_EQ(p.joint.loop_closure_age, 0.0);
  EXPECT_EQ(p.paper.sensor.detection_probability, 1.0);
  EXPECT_EQ(p.paper.sensor.max_range,
            std::stod(sim::associatorParametersFor(world, "DJNN").at("sensor_range")));
}

TEST(Evaluate, UnknownAssociatorListsTheAvailableOnes) {
  EvaluateOptions o = tinyOptions("/nonexistent");
  o.associators = {"ekf_slam/DJN"};
  std::ostringstream log;
  try {
    runEvaluation(o, log);
    FAIL() << "no exception";
  } catch (const UnknownAssociatorError& e) {
    EXPECT_NE(std::string(e.what()).find("ekf_slam/DJNN"), std::string::npos) << e.what();
  }
}

TEST(Evaluate, CommandLine) {
  const TempDir tmp("evaluate");
  const std::string dir = tmp.path().string();
  const std::string cmd = std::string(EVALUATE_BIN) + " --world tiny --runs 1 --associators DJNN" +
                          " --no-progress --out " + dir + " > " + dir + "/stdout.txt 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << readFile(dir + "/stdout.txt");
  EXPECT_TRUE(fs::exists(dir + "/summary.md"));
  EXPECT_NE(readFile(dir + "/stdout.txt").find("| DJNN |"), std::string::npos);
  const std::string bad = std::string(EVALUATE_BIN) + " --world tiny > /dev/null 2>&1";
  const int rc = std::system(bad.c_str());
  EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 2);
}

}  // namespace test_evaluate
}  // namespace ekf_slam
