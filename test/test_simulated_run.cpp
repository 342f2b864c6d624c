// A simulated run through the SlamPipeline, scored against the truth: world parameters, the
// scorer's bookkeeping, and a regression guard on DJNN's accuracy.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace ekf_slam {
namespace test_simulated_run {

std::shared_ptr<DataAssociation> makeDjnn(const sim::World& w) {
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(w, "DJNN")));
  return djnn;
}

TEST(WorldParameters, MatchTheWorld) {
  const sim::World w = sim::makeWorld("hybrid");
  const PipelineConfig c = sim::pipelineConfigFor(w);
  EXPECT_EQ(c.odometry_mode, "twist");
  EXPECT_DOUBLE_EQ(c.sigma_range, w.noise.sigma_range);
  EXPECT_DOUBLE_EQ(c.sigma_bearing, w.noise.sigma_bearing);
  EXPECT_DOUBLE_EQ(c.twist.sigma_v, sim::twistNoiseFor(w).sigma_v);
  EXPECT_DOUBLE_EQ(c.twist.sigma_w_per_v, sim::twistNoiseFor(w).sigma_w_per_v);
  EXPECT_DOUBLE_EQ(c.max_observation_range, w.sensor.max_range);
  EXPECT_TRUE(c.initial_pose.isApprox(w.start_pose));
  EXPECT_TRUE(sim::associatorParametersFor(w, "NN").empty());
  EXPECT_EQ(sim::associatorParametersFor(w, "DJNN").at("sensor_range"), "30");
}

TEST(WorldParameters, WholeMapWorldsGetACoveringRange) {
  const sim::World w = sim::makeWorld("rrw_noise_1");
  ASSERT_FALSE(std::isfinite(w.sensor.max_range));
  const double diagonal = (w.area_max - w.area_min).norm();
  EXPECT_GE(sim::pipelineConfigFor(w).max_observation_range, diagonal);
  const auto djnn = sim::associatorParametersFor(w, "DJNN");
  EXPECT_GE(std::stod(djnn.at("sensor_range")), diagonal);
  EXPECT_LE(std::stod(djnn.at("field_of_view")), 2.0 * M_PI);
  // Both are accepted by the code that reads them.
  DJNN d;
  EXPECT_NO_THROW(d.configure(MapParameterSource(djnn)));
}

// DJNN's landmark_density means "unmapped landmarks per m^2 where the sensor looks": a corridor
// the camera sweeps holds its markers at a density far above the world's box's. A room seen by a
// camera that looks through its walls counts only the room's floor.
TEST(WorldParameters, LandmarkDensityIsPerGroundTheSensorCovers) {
  sim::World w = sim::makeWorld("fiducials");
  w.area_min = {-1.0, -10.0};
  w.area_max = {25.0, 10.0};
  w.landmarks.clear();
  for (double x = 2.0; x <= 18.0 + 1e-9; x += 0.5) {
    w.landmarks.emplace_back(x, 0.5);
    w.landmarks.emplace_back(x, -0.5);
  }
  w.start_pose = Eigen::Vector3d::Zero();
  w.waypoints = {{20.0, 0.0}};
  w.sensor.polygon = {{0.5, -1.0}, {2.5, -1.0}, {2.5, 1.0}, {0.5, 1.0}};
  const double density = sim::coveredLandmarkDensity(w);
  // The band 2 m wide from x = 0.5 to about 20 + 2.5 m.
  const double expected = double(w.landmarks.size()) / (2.0 * 22.0);
  EXPECT_NEAR(density, expected, 0.1 * expected);
  const Eigen::Vector2d box = w.area_max - w.area_min;
  EXPECT_GT(density, 5.0 * double(w.landmarks.size()) / (box.x() * box.y()));
  // Only the oracle's configuration holds it (a user does not know the density).
  EXPECT_NEAR(
      std::stod(
          sim::associatorParametersFor(w, "DJNN", sim::Knowledge::kOracle).at("landmark_density")),
      density, 1e-9);
  EXPECT_EQ(sim::associatorParametersFor(w, "DJNN").count("landmark_density"), 0u);

  const sim::World arena = sim::makeWorld("arena");
  EXPECT_NEAR(sim::coveredLandmarkDensity(arena), 15.0 / (6.0 * 8.0), 0.03);

  // A sensor without a range limit sees the whole area: the density is the area's (and the
  // cost per view stays bounded).
  sim::World tiny = sim::makeWorld("tiny");
  tiny.sensor.max_range = std::numeric_limits<double>::infinity();
  tiny.sensor.field_of_view = 2.0 * M_PI;
  tiny.max_duration = 2.0;
  const Eigen::Vector2d extent = tiny.area_max - tiny.area_min;
  EXPECT_NEAR(sim::coveredLandmarkDensity(tiny), double(tiny.landmarks.size()) / extent.prod(),
              0.05 * double(tiny.landmarks.size()) / extent.prod());
}

// The default filter (jacobians: auto) is the FEJ-EKF wherever the full EKF runs without
// second-order observation terms; the worlds whose far landmarks need those terms (rrw: 3 deg at
// 425 m, where FEJ diverges) run the invariant EKF, and the compressed filter's city the standard
// Jacobians. No world chooses its own filter.
TEST(WorldParameters, DefaultFilterIsFejUnlessFarLandmarksNeedSecondOrderTerms) {
  const std::vector<std::pair<const char*, Linearisation>> expected = {
      {"fiducials", Linearisation::kFirstEstimate},
      {"fiducials_lattice", Linearisation::kFirstEstimate},
      {"arena", Linearisation::kFirstEstimate},
      {"djnn_weak", Linearisation::kFirstEstimate},
      {"hybrid", Linearisation::kFirstEstimate},
      {"aekf", Linearisation::kFirstEstimate},
      {"rrw_noise_1", Linearisation::kInvariant},
      {"rrw_occlusion_2", Linearisation::kInvariant},
      {"city", Linearisation::kStandard}};
  for (const auto& [name, linearisation] : expected)
    EXPECT_EQ(sim::pipelineConfigFor(sim::makeWorld(name)).linearisation(), linearisation) << name;
  for (const std::string& name : sim::worldNames())
    EXPECT_EQ(sim::pipelineParametersFor(sim::makeWorld(name)).count("jacobians"), 0u) << name;
}

TEST(RunScorer, RejectsMisalignedTruth) {
  RunScorer scorer;
  ScanReport report;
  report.observations.resize(2);
  report.association.resize(2);
  EXPECT_THROW(
      scorer.addScan(report, {1}, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), nullptr),
      std::invalid_argument);
}

TEST(RunScorer, CountsScansAndSkipsEarlyNees) {
  RunScorer scorer(/*nees_skip_s=*/1.0);
  const Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d truth = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) {
    ScanReport r;
    r.stamp = 10.0 + 0.5 * k;  // 10, 10.5 skipped; 11, 11.5 counted
    r.observations.resize(1);
    r.association.resize(1);
    r.association.decision[0] = Decision::kNew;
    r.association.landmark[0] = k;
    r.association_s = 1e-6;
    scorer.addScan(r, {k}, Eigen::Vector3d(k, 0, 0), cov, &truth);
  }
  const RunMetrics m = scorer.metrics(nullptr);
  EXPECT_EQ(m.scans, 4u);
  EXPECT_EQ(m.observations, 4u);
  EXPECT_EQ(m.counts.tn, 4u);  // four new landmarks, correctly left unpaired
  EXPECT_EQ(m.map.landmarks, 4u);
  EXPECT_EQ(m.nees_scans, 2u);
  EXPECT_DOUBLE_EQ(m.anees, (4.0 + 9.0) / 2.0);  // NEES = x^2 with unit covariance
  EXPECT_DOUBLE_EQ(m.pose_rmse_m, std::sqrt((0.0 + 1.0 + 4.0 + 9.0) / 4.0));
  EXPECT_NEAR(m.association_us_mean, 1.0, 1e-9);
  ASSERT_EQ(scorer.neesPerScan().size(), 4u);
  EXPECT_DOUBLE_EQ(scorer.neesPerScan()[1], 1.0);
}

TEST(RunScorer, ErrorsBeforeAndAfterTheKidnap) {
  // Scans at 5 Hz with a position error of 0.1 k m at scan k; the kidnap comes before scan 3.
  RunScorer scorer;
  const Eigen::Vector3d truth = Eigen::Vector3d::Zero();
  for (int k = 0; k < 20; ++k) {
    if (k == 3) scorer.markKidnap();
    ScanReport r;
    r.stamp = 0.2 * k;
    scorer.addScan(r, {}, Eigen::Vector3d(0.1 * k, 0, 0), Eigen::Matrix3d::Identity(), &truth);
  }
  const RunMetrics m = scorer.metrics(nullptr);
  EXPECT_NEAR(m.error_before_kidnap_m, 0.2, 1e-12);  // scan 2
  EXPECT_NEAR(m.error_after_kidnap_m, 1.3, 1e-12);   // scan 13, kRecoveryWindow after scan 3
  EXPECT_EQ(m.recovery_scans, 0);                    // 0.3 m at the kidnap scan itself
  // No kidnap: both NaN.
  RunScorer quiet;
  ScanReport r;
  quiet.addScan(r, {}, truth, Eigen::Matrix3d::Identity(), &truth);
  EXPECT_TRUE(std::isnan(quiet.metrics(nullptr).error_before_kidnap_m));
  EXPECT_TRUE(std::isnan(quiet.metrics(nullptr).error_after_kidnap_m));
}

// A map and a pose both displaced from the truth by the same rigid transform (the filter's
// gauge drift): the pose is right in its map. Six landmarks (ids = truth ids 0..5) seen at scan 0;
// scans at 5 Hz along x; the kidnap comes before scan 5, the relocalisation at scan 7 puts the
// pose `fix_offset` (in the map frame) from where the map says it is, and it stays there. A
// younger duplicate of landmark 0 appears at the kidnapped pose (scan 5), as a filter makes one.
// With `rebuild`, nothing relocalises: at the kidnap the old landmarks are removed and the map
// is rebuilt around the kidnapped pose (DJNN's exit rule), consistent with the displaced estimate.
RunMetrics driftedMapRun(const Eigen::Vector2d& fix_offset, bool rebuild = false) {
  const std::vector<Eigen::Vector2d> landmarks = {{0, 20},   {30, 25},  {60, 18},
                                                  {10, -15}, {40, -22}, {70, -12}};
  const double yaw = 0.04;  // the drift: 0.04 rad about the origin, then (2.5, -1) m
  const Eigen::Vector2d shift(2.5, -1.0);
  const auto drift = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d q = Eigen::Rotation2Dd(yaw) * p.head<2>() + shift;
    return Eigen::Vector3d(q.x(), q.y(), p.z() + yaw);
  };
  RunScorer scorer;
  std::unordered_map<LandmarkId, Eigen::Vector2d> true_map;
  EkfSlam map;
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    true_map[static_cast<LandmarkId>(i)] = landmarks[i];
    map.insertLandmark(drift(Eigen::Vector3d(landmarks[i].x(), landmarks[i].y(), 0)).head<2>(),
                       Eigen::Matrix2d::Identity(), static_cast<LandmarkId>(i));
  }
  scorer.setTrueMap(true_map);
  scorer.expectKidnap();
  const Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();
  for (int k = 0; k < 20; ++k) {
    ScanReport r;
    r.stamp = 0.2 * k;
    std::vector<LandmarkId> truth;
    if (k == 0) {  // every landmark created
      for (std::size_t i = 0; i < landmarks.size(); ++i) truth.push_back(static_cast<int>(i));
      r.observations.resize(truth.size());
      r.association.resize(truth.size());
      for (std::size_t i = 0; i < truth.size(); ++i) {
        r.association.decision[i] = Decision::kNew;
        r.association.landmark[i] = truth[i];
      }
    }
    if (k == 5 && rebuild) {
      scorer.markKidnap();
      r.observations.resize(landmarks.size());
      r.association.resize(landmarks.size());
      for (std::size_t i = 0; i < landmarks.size(); ++i) {
        map.removeLandmark(static_cast<LandmarkId>(i));
        const Eigen::Vector2d at = landmarks[i] - Eigen::Vector2d(30.0, 0.0);
        truth.push_back(static_cast<LandmarkId>(i));
        r.association.decision[i] = Decision::kNew;
        r.association.landmark[i] =
            map.insertLandmark(drift(Eigen::Vector3d(at.x(), at.y(), 0)).head<2>(),
                               Eigen::Matrix2d::Identity(), static_cast<LandmarkId>(200 + i));
      }
    } else if (k == 5) {  // the duplicate of landmark 0, made at the kidnapped pose
      scorer.markKidnap();
      truth = {0};
      r.observations.resize(1);
      r.association.resize(1);
      r.association.decision[0] = Decision::kNew;
      r.association.landmark[0] = map.insertLandmark({-40, 60}, Eigen::Matrix2d::Identity(), 100);
    }
    // The truth drives along x and is kidnapped 30 m further on at scan 5.
    const Eigen::Vector3d true_pose(2.0 * k + (k >= 5 ? 30.0 : 0.0), 0.0, 0.1);
    Eigen::Vector3d estimate = drift(true_pose);
    if (k == 5 || k == 6) estimate = drift(Eigen::Vector3d(2.0 * k, 0.0, 0.1));   // not yet found
    if (rebuild && k >= 5) estimate = drift(Eigen::Vector3d(2.0 * k, 0.0, 0.1));  // never found
    if (!rebuild && k >= 7) estimate.head<2>() += fix_offset;
    if (!rebuild && k == 7) {
      r.relocalised = true;
      r.relocalisation.pose = estimate;
    }
    scorer.addScan(r, truth, estimate, cov, &true_pose, &map);
  }
  return scorer.metrics(nullptr);
}

TEST(RunScorer, RecoveryAgainstTheMapIgnoresTheMapsRigidDrift) {
  const RunMetrics m = driftedMapRun(Eigen::Vector2d::Zero());
  // In the world frame the drift alone is 2.6-2.8 m: never "recovered", the fix "wrong".
  EXPECT_GT(m.error_before_kidnap_m, 2.0);
  EXPECT_EQ(m.recovery_scans, -1);
  EXPECT_EQ(m.relocalisations, 1u);
  EXPECT_EQ(m.wrong_relocalisations, 1u);
  // Against the map: exact before, recovered at the relocalisation (2 scans after the kidnap),
  // the fix right; the duplicate at the kidnapped pose does not move the alignment.
  EXPECT_NEAR(m.error_before_kidnap_map_m, 0.0, 1e-9);
  EXPECT_EQ(m.recovery_scans_map, 2);
  EXPECT_NEAR(m.recovery_s_map, 0.4, 1e-9);
  EXPECT_NEAR(m.error_after_kidnap_map_m, 0.0, 1e-9);  // scan 15
  EXPECT_EQ(m.wrong_relocalisations_map, 0u);
}

TEST(RunScorer, APoseWrongInItsMapIsNotRecovered) {
  // 1.5 m off in its own map: not recovered (over 1 m), not a wrong fix (under 2 m) ...
  const RunMetrics m = driftedMapRun(Eigen::Vector2d(0.0, 1.5));
  EXPECT_EQ(m.recovery_scans_map, -1);
  EXPECT_TRUE(std::isnan(m.recovery_s_map));
  EXPECT_NEAR(m.error_after_kidnap_map_m, 1.5, 1e-9);
  EXPECT_EQ(m.wrong_relocalisations_map, 0u);
  // ... 3 m off: a wrong fix in its map.
  EXPECT_EQ(driftedMapRun(Eigen::Vector2d(3.0, 0.0)).wrong_relocalisations_map, 1u);
}

TEST(RunScorer, AMapRebuiltAroundTheKidnappedPoseIsNotARecovery) {
  // The rebuilt landmarks carry the true identities and agree with the displaced estimate, so a
  // fit on them would call the pose right; only landmarks made before the kidnap count.
  const RunMetrics m = driftedMapRun(Eigen::Vector2d::Zero(), /*rebuild=*/true);
  EXPECT_NEAR(m.error_before_kidnap_map_m, 0.0, 1e-9);
  EXPECT_EQ(m.relocalisations, 0u);
  EXPECT_EQ(m.recovery_scans_map, -1);
  EXPECT_TRUE(std::isnan(m.error_after_kidnap_map_m));  // the old map is gone: nothing to fit
}

TEST(RunScorer, MapRelativeErrorNeedsThreeIdentifiedLandmarks) {
  RunScorer scorer;
  scorer.setTrueMap({{0, Eigen::Vector2d(0, 10)}, {1, Eigen::Vector2d(10, 0)}});
  EkfSlam map;
  ScanReport r;
  r.observations.resize(2);
  r.association.resize(2);
  for (int i = 0; i < 2; ++i) {
    r.association.decision[i] = Decision::kNew;
    r.association.landmark[i] =
        map.insertLandmark(Eigen::Vector2d(10.0 * i, 10.0 - 10.0 * i), Eigen::Matrix2d::Identity());
  }
  const Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  scorer.addScan(r, {0, 1}, pose, Eigen::Matrix3d::Identity(), &pose, &map);
  EXPECT_TRUE(std::isnan(scorer.mapRelativeError(map, pose, pose).position));
  EXPECT_TRUE(std::isnan(scorer.mapRelativeError(map, pose, pose).heading));
}

// Regression guard, generous on purpose: the tiny world (8 landmarks, a mover, clutter) through
// the whole pipeline with DJNN.
TEST(RunSimulation, TinyWorldWithDjnn) {
  const sim::World w = sim::makeWorld("tiny");
  const RunMetrics m = runSimulation(w, 1, sim::pipelineConfigFor(w), makeDjnn(w));
  std::printf(
      "tiny/DJNN: accuracy %.4f precision %.4f recall %.4f, map %zu (%zu spurious), "
      "RMSE %.3f m, ANEES %.2f, %.1f us per association\n",
      m.counts.accuracy(), m.counts.precision(), m.counts.recall(), m.map.landmarks, m.map.spurious,
      m.pose_rmse_m, m.anees, m.association_us_mean);
  EXPECT_GT(m.scans, 100u);
  EXPECT_GT(m.counts.accuracy(), 0.95);
  EXPECT_GE(m.map.true_landmarks_mapped, 7u);
  EXPECT_LT(m.pose_rmse_m, 1.0);
  EXPECT_EQ(m.rejected_updates, 0u);
}

// "truth_delayed": the true pairings, each landmark admitted at its 7th sighting with the six
// before it applied at admission (delayed sightings), so that the wait is all it costs.
TEST(RunSimulation, TruthDelayedWaitsAndUsesEverySighting) {
  const sim::World w = sim::makeWorld("tiny");
  const PipelineConfig config = sim::pipelineConfigFor(w);
  ASSERT_TRUE(config.delayed_sightings);
  auto delayed = std::make_shared<KnownAssociation>(7, "truth_delayed");
  delayed->configure(MapParameterSource());
  EXPECT_EQ(delayed->name(), "truth_delayed");
  const RunMetrics now = runSimulation(w, 1, config, std::make_shared<KnownAssociation>());
  const RunMetrics wait = runSimulation(w, 1, config, delayed);
  EXPECT_DOUBLE_EQ(wait.counts.accuracy(), 1.0);
  EXPECT_EQ(wait.map.spurious, 0u);
  // Six sightings per landmark are tentative, not pairings...
  EXPECT_LE(wait.counts.tp + 6 * wait.map.true_landmarks_mapped, now.counts.tp);
  // ... but the filter used them all.
  EXPECT_GT(wait.map.sightings_used, 0.999);
  EXPECT_LT(wait.map.pairing_coverage, wait.map.sightings_used - 0.01);

  // The count is a parameter of its section; 1 is the plain truth.
  auto at_once = std::make_shared<KnownAssociation>(7, "truth_delayed");
  at_once->configure(
      MapParameterSource(std::map<std::string, std::string>{{"admit_sightings", "1"}}));
  EXPECT_EQ(runSimulation(w, 1, config, at_once).counts.tp, now.counts.tp);
  EXPECT_THROW(at_once->configure(MapParameterSource(
                   std::map<std::string, std::string>{{"admit_sightings", "0"}})),
               ParameterError);
}

TEST(RunSimulation, SameSeedSameScores) {
  const sim::World w = sim::makeWorld("tiny");
  std::vector<double> nees_a, nees_b;
  const RunMetrics a = runSimulation(w, 7, sim::pipelineConfigFor(w), makeDjnn(w), &nees_a);
  const RunMetrics b = runSimulation(w, 7, sim::pipelineConfigFor(w), makeDjnn(w), &nees_b);
  EXPECT_EQ(a.counts.tp, b.counts.tp);
  EXPECT_EQ(a.counts.fp, b.counts.fp);
  EXPECT_EQ(a.map.landmarks, b.map.landmarks);
  EXPECT_DOUBLE_EQ(a.pose_rmse_m, b.pose_rmse_m);
  ASSERT_EQ(nees_a.size(), a.scans);
  EXPECT_EQ(nees_a.size(), nees_b.size());
}

// NN keeps every mover and clutter return it ever initialised; DJNN's evidence counter removes
// them: the same run must show it in the final map.
TEST(RunSimulation, DjnnMapHasFewerSpuriousLandmarksThanNn) {
  sim::World w = sim::makeWorld("tiny");
  w.clutter_rate = 1.0;
  auto nn = std::make_shared<NN>();
  nn->configure(MapParameterSource());
  const RunMetrics with_nn = runSimulation(w, 3, sim::pipelineConfigFor(w), nn);
  const RunMetrics with_djnn = runSimulation(w, 3, sim::pipelineConfigFor(w), makeDjnn(w));
  EXPECT_LT(with_djnn.map.spurious, with_nn.map.spurious);
}

}  // namespace test_simulated_run
}  // namespace ekf_slam
