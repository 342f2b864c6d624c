// calibrate_noise on simulated bags whose noise is known (simulate --true-noise): deliberately
// wrong sigmas must come back to the simulator's within 15 %; the smoother's leverage must add up
// to its degrees of freedom; bad arguments are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>

#include <Eigen/LU>

#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/evaluation/simulation/simulator.h"
#include "ekf_slam/evaluation/world_parameters.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/tools/calibrate_noise.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_calibrate_noise {

struct TrueNoiseBag {
  explicit TrueNoiseBag(const std::string& world, std::uint64_t seed) {
    SimulationBagOptions o;
    o.world = world;
    o.seed = seed;
    o.out_path = (dir.path() / (world + ".bag")).string();
    o.markers = false;
    o.true_noise = true;
    std::ostringstream log;
    summary = writeSimulationBag(o, log);
  }
  test_files::TempDir dir;
  SimulationBagSummary summary;
};

double value(const std::map<std::string, std::string>& m, const std::string& key) {
  return std::stod(m.at(key));
}

std::string text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// Starts from the simulator's noise with the odometry's sigmas times `odometry` and the
// observations' times `observation`, and checks what comes back against the simulator's.
void expectRecovered(const std::string& world, std::uint64_t seed, double odometry,
                     double observation) {
  const TrueNoiseBag bag(world, seed);
  const auto truth = sim::trueNoiseParametersFor(sim::makeWorld(world));
  CalibrateNoiseOptions o;
  o.bag_path = bag.summary.bag_path;
  o.params_path = bag.summary.params_path;
  o.out_dir = (bag.dir.path() / "calibration").string();
  o.progress = false;
  const char* odometry_keys[] = {"twist_sigma_v", "twist_sigma_w_per_v"};
  const char* observation_keys[] = {"sigma_range", "sigma_bearing"};
  for (const char* k : odometry_keys)
    o.overrides.push_back({"", k, text(odometry * value(truth, k))});
  for (const char* k : observation_keys)
    o.overrides.push_back({"", k, text(observation * value(truth, k))});
  std::ostringstream log;
  const CalibrateNoiseResult r = calibrateNoiseOnBag(o, log);
  EXPECT_TRUE(r.converged) << log.str();
  for (const char* k : odometry_keys) {
    EXPECT_NEAR(r.before.at(k) / value(truth, k), odometry, 1e-6) << k;
    EXPECT_NEAR(r.after.at(k) / value(truth, k), 1.0, 0.15) << k << "\n" << r.yaml;
  }
  for (const char* k : observation_keys) {
    EXPECT_NEAR(r.before.at(k) / value(truth, k), observation, 1e-6) << k;
    EXPECT_NEAR(r.after.at(k) / value(truth, k), 1.0, 0.15) << k << "\n" << r.yaml;
  }
  // The calibrated filter is consistent by its NIS, and the snippet names what it changed.
  const NisFigures& after = r.runs.back().nis;
  EXPECT_NEAR(after.mean_per_dof, 1.0, 0.1);
  EXPECT_NEAR(after.share_in_band, 0.95, 0.03);
  for (const char* k : {"twist_sigma_v:", "twist_sigma_w_per_v:", "sigma_range:", "sigma_bearing:"})
    EXPECT_NE(r.yaml.find(k), std::string::npos) << k << "\n" << r.yaml;
}

TEST(CalibrateNoise, RecoversTheSimulatorsNoiseFromOdometryTwiceAndObservationsHalf) {
  expectRecovered("djnn_weak", 1, 2.0, 0.5);
}

TEST(CalibrateNoise, RecoversTheSimulatorsNoiseFromOdometryHalfAndObservationsTwice) {
  expectRecovered("djnn_weak", 2, 0.5, 2.0);
}

// Each residual's expected cost at the solution is its dimension less tr(W J N^-1 J^T); summed
// over every residual they are the problem's degrees of freedom (the first scan's prior, its
// pose known exactly, absorbs its own 3): a wrong leverage would not add up.
TEST(CalibrateNoise, LeverageAddsUpToTheDegreesOfFreedom) {
  const TrueNoiseBag bag("tiny", 3);
  OfflineOptions o = test_files::quietOfflineOptions(bag.summary.bag_path, bag.summary.params_path,
                                                     (bag.dir.path() / "run").string());
  SmoothingRecorder recorder;
  std::vector<SmoothingLandmark> landmarks;
  std::unique_ptr<RangeBearingModel> model;
  o.on_scan = [&](const ScanReport& r, const SlamPipeline& p) { recorder.add(r, p); };
  o.on_finish = [&](const SlamPipeline& p) {
    landmarks = recorder.landmarks(p);
    model = std::make_unique<RangeBearingModel>(p.observationModel());
  };
  std::ostringstream log;
  runOffline(o, log);
  SmootherParams params;
  params.residuals = true;
  params.landmark_covariances = 0;
  const SmoothingResult r = smoothRun(recorder.scans(), landmarks, *model, params);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.residuals.size(), r.observations + recorder.scans().size() - 1);
  double expected = 0.0;
  for (const SmoothingResidual& res : r.residuals) {
    const SmoothingScan& s = recorder.scans()[res.scan];
    const int d = res.observation < 0 ? 3 : 2;
    Eigen::MatrixXd C = res.observation < 0 ? Eigen::MatrixXd(s.motion_covariance)
                                            : Eigen::MatrixXd(s.observations[res.observation].R);
    if (d == 3) C.diagonal().array() += params.min_variance;
    const Eigen::MatrixXd W = C.inverse();
    expected += d - (W * res.leverage.topLeftCorner(d, d)).trace();
  }
  EXPECT_NEAR(expected, static_cast<double>(r.degrees_of_freedom), 1e-3 * r.degrees_of_freedom);
}

// The odometry noise's shares by term add up to the whole: in the model (with and without the
// steering form, per message and per second) and composed over a scan's messages (no additive
// noise in the file).
TEST(CalibrateNoise, NoiseSharesAddUpToTheCovariance) {
  for (const double wheelbase : {0.0, 2.0})
    for (const bool per_second : {false, true}) {
      TwistParams p;
      p.steering_wheelbase = wheelbase;
      p.per_second = per_second;
      const TwistModel model(p);
      for (const Eigen::Vector2d& u : {Eigen::Vector2d(3.0, 0.4), Eigen::Vector2d(0.0, 0.1)}) {
        const MotionStep s = model.step(Eigen::Vector3d(1.0, 2.0, 0.3), u, 0.05);
        EXPECT_TRUE(s.Q.isApprox(s.Q_translation + s.Q_rotation, 1e-12)) << s.Q;
        EXPECT_GT(s.Q_rotation.norm(), 0.0);
      }
    }
  const TrueNoiseBag bag("tiny", 4);
  OfflineOptions o = test_files::quietOfflineOptions(bag.summary.bag_path, bag.summary.params_path,
                                                     (bag.dir.path() / "run").string());
  int checked = 0;
  o.on_scan = [&](const ScanReport& r, const SlamPipeline&) {
    if (!r.has_motion) return;
    ++checked;
    const Eigen::Matrix3d sum = r.motion_covariance_translation + r.motion_covariance_rotation;
    EXPECT_LT((sum - r.motion_covariance).norm(), 1e-9 * r.motion_covariance.norm());
  };
  std::ostringstream log;
  runOffline(o, log);
  EXPECT_GT(checked, 100);
}

// The same parameter rules as every entry point (it is the offline runner's builder).
TEST(CalibrateNoise, NamesAMisspeltParameter) {
  const TrueNoiseBag bag("tiny", 5);
  CalibrateNoiseOptions o;
  o.bag_path = bag.summary.bag_path;
  o.params_path = bag.summary.params_path;
  o.out_dir = (bag.dir.path() / "calibration").string();
  o.progress = false;
  o.overrides.push_back({"", "sigma_rnage", "0.1"});
  std::ostringstream log;
  try {
    calibrateNoiseOnBag(o, log);
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean sigma_range"), std::string::npos)
        << e.what();
  }
}

TEST(CalibrateNoise, RefusesBadArguments) {
  CalibrateNoiseOptions o;
  bool help = false;
  std::string error;
  EXPECT_FALSE(parseCalibrateNoiseArguments({"--bag", "b.bag"}, &o, &help, &error));
  EXPECT_NE(error.find("--out"), std::string::npos) << error;
  EXPECT_FALSE(
      parseCalibrateNoiseArguments({"--bag", "b", "--out", "d", "--set", "x"}, &o, &help, &error));
  EXPECT_NE(error.find("NAME=VALUE"), std::string::npos) << error;
  EXPECT_FALSE(
      parseCalibrateNoiseArguments({"--bag", "b", "--out", "d", "--runs", "0"}, &o, &help, &error));
  EXPECT_TRUE(parseCalibrateNoiseArguments(
      {"--bag", "b", "--out", "d", "--set", "DJNN/gate=0.9", "--runs", "2"}, &o, &help, &error))
      << error;
  ASSERT_EQ(o.overrides.size(), 1u);
  EXPECT_EQ(o.overrides[0].section, "DJNN");
  EXPECT_EQ(o.overrides[0].name, "gate");
  EXPECT_EQ(o.max_runs, 2);
}

}  // namespace test_calibrate_noise
}  // namespace ekf_slam
