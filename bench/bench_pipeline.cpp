// Synthetic timing of a Victoria-Park-sized SLAM run through SlamPipeline with DJNN: 60000
// odometry messages (40 Hz twist) and 7000 observation sets, from a simulated vehicle driving
// loops through a park of point trees. Prints wall times; asserts nothing (numbers, not tests).
//
//   bench_pipeline [odometry_messages=60000] [scans=7000] [trees=200] [odometry_correction=none]
// 200 trees in the 260 m square put about 4 within the 30 m half disc, as in Victoria Park.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"

using ekf_slam::Observation;

int main(int argc, char** argv) {
  const int n_odom = argc > 1 ? std::atoi(argv[1]) : 60000;
  const int n_scans = argc > 2 ? std::atoi(argv[2]) : 7000;
  const int n_trees = argc > 3 ? std::atoi(argv[3]) : 200;
  const char* correction = argc > 4 ? argv[4] : "none";  // AEKF states (docs/parameters.md)
  const double dt = 0.025;
  const int scan_every = std::max(1, n_odom / std::max(1, n_scans));

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-130.0, 130.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<Eigen::Vector2d> trees;
  while (static_cast<int>(trees.size()) < n_trees) {
    const Eigen::Vector2d p(u(rng), u(rng));
    bool ok = true;  // keep trees apart so that association is well posed
    for (const auto& q : trees) ok = ok && (p - q).norm() > 4.0;
    if (ok) trees.push_back(p);
  }

  ekf_slam::PipelineConfig config;
  config.initial_pose = Eigen::Vector3d(80.0, 0.0, M_PI / 2);
  config.correction.mode = correction;
  auto djnn = std::make_shared<ekf_slam::DJNN>();
  djnn->configure(ekf_slam::MapParameterSource());
  ekf_slam::SlamPipeline pipeline(config, djnn);

  const double v = 3.0, w = v / 80.0;  // a circle of radius 80 m, some wobble below
  Eigen::Vector3d truth = config.initial_pose;
  const ekf_slam::TwistModel exact;
  const double sr = config.sigma_range, sb = config.sigma_bearing;

  double t_odom = 0.0, t_scan = 0.0, t_assoc = 0.0, t_update = 0.0;
  int scans = 0;
  std::size_t max_landmarks = 0;
  std::uint64_t paired = 0;
  const auto t_all = std::chrono::steady_clock::now();
  for (int k = 0; k < n_odom; ++k) {
    const double stamp = k * dt;
    const Eigen::Vector2d twist(v, w + 0.05 * std::sin(0.01 * k));
    ekf_slam::OdometryInput odom;
    odom.stamp = stamp;
    odom.twist = twist + Eigen::Vector2d(0.05 * n01(rng), 0.005 * n01(rng));
    auto t0 = std::chrono::steady_clock::now();
    pipeline.addOdometry(odom);
    t_odom += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    truth = exact.predict(truth, twist, dt);

    if (k % scan_every == 0 && scans < n_scans) {
      std::vector<Observation> obs;
      for (const auto& p : trees) {
        Observation o;
        o.z = pipeline.observationModel().predict(truth, p);
        if (o.z(0) > 30.0 || std::abs(o.z(1)) > M_PI / 2) continue;
        o.z += Eigen::Vector2d(sr * n01(rng), sb * n01(rng));
        o.z(1) = ekf_slam::wrapAngle(o.z(1));
        o.R = Eigen::Vector2d(sr * sr, sb * sb).asDiagonal();
        obs.push_back(o);
      }
      t0 = std::chrono::steady_clock::now();
      const ekf_slam::ScanReport r = pipeline.processObservations(stamp + 0.3 * dt, obs);
      t_scan += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      t_assoc += r.association_s;
      t_update += r.update_s;
      for (auto d : r.association.decision) paired += d == ekf_slam::Decision::kPaired;
      ++scans;
      max_landmarks = std::max(max_landmarks, pipeline.ekf().numLandmarks());
    }
  }
  const double total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count();
  const Eigen::Vector3d err = pipeline.pose() - truth;
  std::printf(
      "bench_pipeline: %d odometry messages, %d scans, %zu landmarks (max %zu), "
      "%llu pairings, odometry_correction %s\n",
      n_odom, scans, pipeline.ekf().numLandmarks(), max_landmarks,
      static_cast<unsigned long long>(paired), correction);
  std::printf(
      "  total %.3f s (including simulation) | addOdometry %.4f s (%.1f ns/msg) | "
      "scans %.3f s (%.1f us/scan)\n",
      total, t_odom, 1e9 * t_odom / n_odom, t_scan, 1e6 * t_scan / std::max(1, scans));
  std::printf(
      "  of which association %.3f s, EKF update/initialise/remove %.3f s, "
      "prediction + rest %.3f s\n",
      t_assoc, t_update, t_scan - t_assoc - t_update);
  std::printf("  final pose error %.3f m, %.4f rad\n", err.head<2>().norm(),
              std::abs(ekf_slam::wrapAngle(err(2))));
  return 0;
}
