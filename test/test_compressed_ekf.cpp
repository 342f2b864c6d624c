// The compressed EKF (filter cekf) against the full EKF on a simulated world: the same pose at
// every scan, the same active landmarks, the same whole state at the end (docs/cekf.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace ekf_slam {
namespace test_compressed_ekf {

constexpr double kTolerance = 1e-8;

// |a - b| relative to max(1, |a|), elementwise maximum.
double difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return 1e300;
  return ((a - b).array().abs() / a.array().abs().max(1.0)).maxCoeff();
}

struct Scan {
  Eigen::Vector3d pose;
  Eigen::Matrix3d pose_cov;
  std::vector<LandmarkId> active;  // landmarks whose estimate is current (all with filter ekf)
  std::vector<Eigen::Vector2d> active_mean;
  bool compressed = false;
  Eigen::MatrixXd stored;  // the global filter's whole covariance as it stands (one scan only)
};

struct Outcome {
  std::vector<Scan> scans;
  Eigen::VectorXd mean;
  Eigen::MatrixXd cov;
  std::vector<LandmarkId> ids;
  CompressedEkfStats stats;
  std::vector<CekfClosure> closures;  // the global updates' log
  double reach = 0.0;                 // rule 1's radius around the sensor [m]
};

std::shared_ptr<DataAssociation> associator(const std::string& name, const sim::World& world) {
  if (name == "truth") return std::make_shared<KnownAssociation>();
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  return djnn;
}

// The world fed to a pipeline as runSimulationOn feeds it, with a look at the filter after each
// scan that never brings the compressed filter up to date (activeEkf()).
Outcome run(const std::string& world_name, const std::string& filter, const std::string& assoc,
            double area, int snapshot_scan = -1, double slack = 0.0) {
  const sim::World world = sim::makeWorld(world_name);
  std::map<std::string, std::string> params = sim::pipelineParametersFor(world);
  params["filter"] = filter;
  params["cekf_area_size"] = std::to_string(area);
  params["cekf_margin"] = "3";
  params["cekf_area_slack"] = std::to_string(slack);
  // The compressed filter keeps no pose clones: both admit new landmarks from their last sighting.
  params["delayed_sightings"] = "false";
  // ... nor first estimates: both linearise at the current estimate.
  params["jacobians"] = "standard";
  const PipelineConfig config = readPipelineConfig(MapParameterSource(params));
  std::shared_ptr<DataAssociation> a = associator(assoc, world);
  auto* known = dynamic_cast<KnownAssociation*>(a.get());
  SlamPipeline pipeline(config, a);
  pipeline.setSensorOffset(world.sensor.offset);
  Outcome out;
  out.reach = config.max_observation_range + config.cekf_margin;
  if (CompressedEkf* c = pipeline.compressedEkf()) c->setClosureLog(&out.closures);
  sim::Simulation simulation(world, 1);
  feedSimulation(simulation, pipeline, [&](const sim::ObservationSet& set) {
    if (known != nullptr) known->setTruth(set.truthIds());
    pipeline.processObservations(set.stamp + sim::kStampOffset, set.toObservations());
    Scan s;
    s.pose = pipeline.pose();
    s.pose_cov = pipeline.poseCovariance();
    const EkfSlam& ekf = pipeline.activeEkf();
    const CompressedEkf* cekf = pipeline.compressedEkf();
    s.compressed = cekf != nullptr && cekf->compressed();
    for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
      const LandmarkId id = ekf.landmarkIds()[k];
      if (s.compressed && !cekf->active(id)) continue;
      s.active.push_back(id);
      s.active_mean.push_back(ekf.landmark(static_cast<int>(k)));
    }
    if (static_cast<int>(out.scans.size()) == snapshot_scan) s.stored = ekf.covariance();
    out.scans.push_back(s);
    return true;
  });
  const EkfSlam& ekf = pipeline.ekf();  // cekf: the global update
  out.mean = ekf.mean();
  out.cov = ekf.covariance();
  out.ids = ekf.landmarkIds();
  if (pipeline.compressedEkf() != nullptr) out.stats = pipeline.compressedEkf()->stats();
  return out;
}

void expectSame(const Outcome& full, const Outcome& cekf) {
  ASSERT_EQ(full.scans.size(), cekf.scans.size());
  for (std::size_t k = 0; k < full.scans.size(); ++k) {
    const Scan& f = full.scans[k];
    const Scan& c = cekf.scans[k];
    ASSERT_LT(difference(f.pose, c.pose), kTolerance) << "scan " << k;
    ASSERT_LT(difference(f.pose_cov, c.pose_cov), kTolerance) << "scan " << k;
    for (std::size_t j = 0; j < c.active.size(); ++j) {
      const auto it = std::find(f.active.begin(), f.active.end(), c.active[j]);
      ASSERT_NE(it, f.active.end()) << "scan " << k << " landmark " << c.active[j];
      ASSERT_LT(difference(f.active_mean[it - f.active.begin()], c.active_mean[j]), kTolerance)
          << "scan " << k << " landmark " << c.active[j];
    }
  }
  ASSERT_EQ(full.ids, cekf.ids);
  EXPECT_LT(difference(full.mean, cekf.mean), kTolerance);
  EXPECT_LT(difference(full.cov, cekf.cov), kTolerance);
}

// Small areas: many global updates (the vehicle leaves its area every few seconds).
TEST(CompressedEkf, EqualsFullEkfWithTrueAssociations) {
  const Outcome full = run("djnn_weak", "ekf", "truth", 10.0);
  const Outcome cekf = run("djnn_weak", "cekf", "truth", 10.0);
  expectSame(full, cekf);
  EXPECT_GT(cekf.stats.compressed_phases, 5u);
  EXPECT_GT(cekf.stats.global_updates, 5u);
  EXPECT_GT(cekf.stats.landmark_in_reach, 0u);
}

// cekf_area_slack widens A beyond rule 1's radius: the same result, fewer global updates for
// landmarks coming within reach (the pose estimate moves against the map before they do).
TEST(CompressedEkf, AreaSlackKeepsTheResultAndClosesLess) {
  const Outcome full = run("djnn_weak", "ekf", "truth", 10.0);
  const Outcome tight = run("djnn_weak", "cekf", "truth", 10.0);
  const Outcome slack = run("djnn_weak", "cekf", "truth", 10.0, -1, 10.0);
  expectSame(full, slack);
  EXPECT_LT(slack.stats.landmark_in_reach, tight.stats.landmark_in_reach);
  EXPECT_GT(slack.stats.max_active_states, tight.stats.max_active_states);
}

// The log of the global updates says why and where each happened (bench_cekf --closures).
TEST(CompressedEkf, ClosureLogMatchesStats) {
  const Outcome cekf = run("djnn_weak", "cekf", "truth", 10.0);
  ASSERT_EQ(cekf.closures.size(), cekf.stats.global_updates);
  std::map<CekfClosureReason, std::uint64_t> count;
  for (const CekfClosure& c : cekf.closures) {
    ++count[c.reason];
    EXPECT_GT(c.opened_states, 3);
    EXPECT_GE(c.states, static_cast<std::size_t>(c.active_states));
    if (c.reason == CekfClosureReason::kLandmarkInReach) {
      // Rule 1 fired on a landmark of B near the sensor (the sensor sits near the vehicle).
      ASSERT_TRUE(c.trigger.allFinite());
      EXPECT_LT((c.trigger - c.pose.head<2>()).norm(), cekf.reach + 5.0);
    }
  }
  EXPECT_EQ(count[CekfClosureReason::kGrown], cekf.stats.grown);
  EXPECT_EQ(count[CekfClosureReason::kLandmarkInReach], cekf.stats.landmark_in_reach);
  EXPECT_EQ(count[CekfClosureReason::kPairingOutside], cekf.stats.pairing_outside);
  EXPECT_EQ(count[CekfClosureReason::kFlush], cekf.stats.flushes);
  EXPECT_LE(count[CekfClosureReason::kFlush], 1u);  // only the final ekf()
}

TEST(CompressedEkf, EqualsFullEkfWithDjnn) {
  // DJNN reads evidence, removes landmarks and counts the whole map: the same decisions.
  const Outcome full = run("djnn_strong", "ekf", "DJNN", 20.0);
  const Outcome cekf = run("djnn_strong", "cekf", "DJNN", 20.0);
  expectSame(full, cekf);
  EXPECT_GT(cekf.stats.global_updates, 2u);
}

// What makes the end state equal is the global update: within a compressed phase the global
// filter's entries outside the active area are stale (so the comparison above can fail).
TEST(CompressedEkf, OutsideTheAreaStaleUntilTheGlobalUpdate) {
  const Outcome cekf0 = run("djnn_weak", "cekf", "truth", 10.0);
  int scan = -1;
  for (std::size_t k = cekf0.scans.size() / 2; k < cekf0.scans.size() && scan < 0; ++k) {
    if (cekf0.scans[k].compressed) scan = static_cast<int>(k);
  }
  ASSERT_GE(scan, 0);
  const Outcome full = run("djnn_weak", "ekf", "truth", 10.0, scan);
  const Outcome cekf = run("djnn_weak", "cekf", "truth", 10.0, scan);
  EXPECT_GT(difference(full.scans[scan].stored, cekf.scans[scan].stored), 1e-6);
  EXPECT_LT(difference(full.cov, cekf.cov), kTolerance);
}

TEST(CompressedEkf, ParametersValidated) {
  using Values = std::map<std::string, std::string>;
  EXPECT_THROW(readPipelineConfig(MapParameterSource(Values{{"filter", "ukf"}})), ParameterError);
  EXPECT_THROW(readPipelineConfig(MapParameterSource(Values{{"cekf_area_size", "0"}})),
               ParameterError);
  EXPECT_THROW(readPipelineConfig(MapParameterSource(Values{{"cekf_margin", "-1"}})),
               ParameterError);
  EXPECT_THROW(readPipelineConfig(MapParameterSource(Values{{"cekf_area_slack", "-1"}})),
               ParameterError);
  const PipelineConfig c = readPipelineConfig(MapParameterSource());
  EXPECT_EQ(c.filter, "ekf");
  EXPECT_EQ(c.cekf_area_slack, 0.0);
}

}  // namespace test_compressed_ekf
}  // namespace ekf_slam
