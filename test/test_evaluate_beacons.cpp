// `evaluate --world beacons`: the laser world goes through evaluate's runs (runSimulation with the
// world's BeaconExtractor) and lands in results.csv / summary.md like the point worlds.
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <string>

#include "ekf_slam/tools/evaluate.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_evaluate_beacons {

using test_files::readFile;
using test_files::TempDir;

TEST(EvaluateBeacons, ScoredLikeTheOtherWorlds) {
  const std::vector<std::string> all = expandWorldNames({"*"});
  EXPECT_NE(std::find(all.begin(), all.end(), "beacons"), all.end());

  const TempDir tmp("evaluate_beacons");
  EvaluateOptions o;
  o.worlds = {"beacons"};
  o.runs = 2;
  o.associators = {"ekf_slam/DJNN", "ekf_slam/NN"};
  o.out_dir = tmp.path().string();
  o.jobs = 1;
  o.progress = false;
  std::ostringstream log;
  const Evaluation e = runEvaluation(o, log);
  ASSERT_EQ(e.rows.size(), 4u);
  for (const EvaluationRow& r : e.rows) {
    SCOPED_TRACE(r.associator + " seed " + std::to_string(r.seed));
    const RunMetrics& m = r.metrics;
    EXPECT_GT(m.scans, 500u);
    EXPECT_GT(m.observations, 1000u);  // extracted from the scans, about 2 per scan
    EXPECT_EQ(m.map.true_landmarks_mapped, 15u);
    EXPECT_GE(m.counts.accuracy(), 0.99);
    EXPECT_LT(m.pose_rmse_m, 0.3);
  }
  writeEvaluation(e, "evaluate --world beacons");
  const std::string summary = readFile(o.out_dir + "/summary.md");
  EXPECT_NE(summary.find("## beacons"), std::string::npos) << summary;
  EXPECT_NE(summary.find("| DJNN |"), std::string::npos) << summary;
  EXPECT_NE(readFile(o.out_dir + "/results.csv").find("\nbeacons,NN,"), std::string::npos);
}

// The true associations in a scan world: each extracted feature's truth is the beacon within
// kLaserTruthDistance of where it points (as the scorer finds it), so they pair every beacon
// sighting and reject the rest: accuracy 1 by the same scorer, every beacon mapped once.
TEST(EvaluateBeacons, TrueAssociationsFromTheExtractedFeatures) {
  EvaluateOptions o;
  o.worlds = {"beacons"};
  o.runs = 1;
  o.associators = {"truth"};
  o.jobs = 1;
  o.progress = false;
  std::ostringstream log;
  const Evaluation e = runEvaluation(o, log);
  ASSERT_EQ(e.rows.size(), 1u);
  const RunMetrics& m = e.rows[0].metrics;
  EXPECT_EQ(m.counts.accuracy(), 1.0);
  EXPECT_GT(m.counts.tp, 1000u);
  EXPECT_EQ(m.map.landmarks_created, 15u);
  EXPECT_EQ(m.map.duplicates, 0u);
}

}  // namespace test_evaluate_beacons
}  // namespace ekf_slam
