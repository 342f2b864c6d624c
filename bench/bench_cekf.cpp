// Full EKF against the compressed EKF on a simulated world (docs/benchmarks.md, "Compressed
// EKF"): time per scan against map size, the real-time factor, the global updates. The true
// associations, so that both filters see the same pairings and only the filter is timed.
//
//   bench_cekf --world city --filter cekf [--area A] [--slack S] [--margin 10] [--max-scans N]
//              [--every 1000] [--seed 1] [--start-at T [--prior-sigma 0.5]] [--closures FILE]
// Prints one row per `every` scans (mean time per scan over those scans) and a summary. --area:
// cekf_area_size, --slack: cekf_area_slack, by default the world's (sim::pipelineParametersFor:
// 150 m and 5 m for city).
//
// --start-at T: the filters start at drive time T [s] on a map that already holds every landmark
// the vehicle observed before T (the true positions plus N(0, prior-sigma^2) noise, loaded as a
// saved map: uncorrelated, but P is dense either way, so every step costs what it costs after
// the drive), from the true pose at T. This times the crossing of the mapped grid at N >= 20 000
// without the hour of driving up to it (docs/benchmarks.md).
// --closures FILE: one CSV row per global update (why, where, A's size; docs/cekf.md).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/evaluation/simulated_run.h"

namespace {

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Process CPU time [s]: on a machine shared with other jobs the wall time measures them too.
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// Drives `simulation` without a filter up to the first scan at or after `start_at` and writes
// every static landmark observed before it to `map_path` (a saved map: the true position plus
// N(0, sigma^2) noise, covariance sigma^2 I; ids are the truth ids). Returns the true pose at
// that scan (the scan itself is dropped).
Eigen::Vector3d priorMap(ekf_slam::sim::Simulation& simulation, const ekf_slam::sim::World& world,
                         double start_at, double sigma, std::uint64_t seed,
                         const std::string& map_path, std::size_t* count) {
  using namespace ekf_slam;
  std::set<LandmarkId> seen;
  Eigen::Vector3d pose = world.start_pose;
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e != sim::Simulation::Event::kObservations) continue;
    const sim::ObservationSet& set = simulation.observations();
    pose = set.true_pose;
    if (set.stamp >= start_at) break;
    for (const LandmarkId id : set.truthIds()) {
      if (sim::isStaticLandmark(id)) seen.insert(id);
    }
  }
  sim::Random noise(sim::Random::streamSeed(seed, 0x9e1));
  std::ofstream out(map_path);
  out.precision(17);
  out << "ekf_slam_map 1\n# bench_cekf prior map: landmarks observed before " << start_at << " s\n";
  const double var = sigma * sigma;
  for (const LandmarkId id : seen) {
    const Eigen::Vector2d& m = world.landmarks[static_cast<std::size_t>(id)];
    out << id << ' ' << m.x() + sigma * noise.normal() << ' ' << m.y() + sigma * noise.normal()
        << ' ' << var << " 0 " << var << " nan 10\n";
  }
  if (!out) throw std::runtime_error("cannot write the prior map '" + map_path + "'");
  *count = seen.size();
  return pose;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ekf_slam;
  std::map<std::string, std::string> o = {
      {"--world", "city"}, {"--filter", "cekf"}, {"--area", ""},
      {"--margin", "10"},  {"--max-scans", "0"}, {"--every", "1000"},
      {"--seed", "1"},     {"--start-at", "0"},  {"--prior-sigma", "0.5"},
      {"--closures", ""},  {"--slack", ""},      {"--prior-map", "/tmp/bench_cekf_prior.map"}};
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!o.count(argv[i])) {
      std::fprintf(stderr,
                   "unknown option %s (options: --world --filter --area --margin "
                   "--max-scans --every --seed --start-at --prior-sigma --prior-map "
                   "--closures --slack)\n",
                   argv[i]);
      return 2;
    }
    o[argv[i]] = argv[i + 1];
  }
  const sim::World world = sim::makeWorld(o["--world"]);
  std::map<std::string, std::string> params = sim::pipelineParametersFor(world);
  params["filter"] = o["--filter"];
  if (!o["--area"].empty()) params["cekf_area_size"] = o["--area"];
  if (!o["--slack"].empty()) params["cekf_area_slack"] = o["--slack"];
  params["cekf_margin"] = o["--margin"];
  const std::uint64_t seed = std::strtoull(o["--seed"].c_str(), nullptr, 10);
  sim::Simulation simulation(world, seed);
  const double start_at = std::atof(o["--start-at"].c_str());
  std::size_t prior_landmarks = 0;
  if (start_at > 0.0) {
    const Eigen::Vector3d pose =
        priorMap(simulation, world, start_at, std::atof(o["--prior-sigma"].c_str()), seed,
                 o["--prior-map"], &prior_landmarks);
    const char* axis[3] = {"x", "y", "yaw"};
    for (int i = 0; i < 3; ++i) {
      char v[64];
      std::snprintf(v, sizeof v, "%.17g", pose(i));
      params[std::string("initial_pose_") + axis[i]] = v;
    }
  }
  const PipelineConfig config = readPipelineConfig(MapParameterSource(params));
  auto known = std::make_shared<KnownAssociation>();
  SlamPipeline pipeline(config, known);
  pipeline.setSensorOffset(world.sensor.offset);
  if (start_at > 0.0) pipeline.loadMap(o["--prior-map"], /*reset_pose=*/true);
  std::vector<CekfClosure> closures;
  std::vector<std::pair<long, double>> closure_scan;  // scan and drive time of each closure
  if (CompressedEkf* c = pipeline.compressedEkf()) c->setClosureLog(&closures);
  const long max_scans = std::atol(o["--max-scans"].c_str());
  const long every = std::max(1L, std::atol(o["--every"].c_str()));

  std::printf("# world %s, filter %s, area %g m, margin %g m, slack %g m, %zu true landmarks\n",
              world.name.c_str(), config.filter.c_str(), config.cekf_area_size, config.cekf_margin,
              config.cekf_area_slack, world.landmarks.size());
  if (start_at > 0.0)
    std::printf("# started at %.1f s on a prior map of %zu landmarks (sigma %s m)\n", start_at,
                prior_landmarks, o["--prior-sigma"].c_str());
  std::printf("%8s %9s %9s %12s %12s %12s %10s %10s %8s\n", "scans", "sim_s", "landmarks",
              "ms_per_scan", "max_ms", "cpu_ms_scan", "wall_s", "cpu_s", "globals");
  const auto t_start = std::chrono::steady_clock::now();
  double filter_s = 0.0, window_s = 0.0, window_max = 0.0, sim_time = 0.0;
  double filter_cpu = 0.0, window_cpu = 0.0;
  double first_stamp = -1.0;  // the drive time timed starts one scan period before it
  long scans = 0;
  feedSimulation(simulation, pipeline, [&](const sim::ObservationSet& set) {
    known->setTruth(set.truthIds());
    // The filter's whole work for the scan: prediction, association, update, global updates.
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpuSeconds();
    pipeline.processObservations(set.stamp + sim::kStampOffset, set.toObservations());
    const double dt = seconds(t0);
    const double dc = cpuSeconds() - c0;
    filter_cpu += dc;
    window_cpu += dc;
    filter_s += dt;
    window_s += dt;
    window_max = std::max(window_max, dt);
    sim_time = set.stamp;
    if (first_stamp < 0.0) first_stamp = set.stamp;
    ++scans;
    while (closure_scan.size() < closures.size()) closure_scan.emplace_back(scans, sim_time);
    if (scans % every == 0) {
      const CompressedEkf* c = pipeline.compressedEkf();
      std::printf("%8ld %9.1f %9zu %12.3f %12.3f %12.3f %10.1f %10.1f %8llu\n", scans, sim_time,
                  pipeline.activeEkf().numLandmarks(), 1e3 * window_s / every, 1e3 * window_max,
                  1e3 * window_cpu / every, filter_s, filter_cpu,
                  c ? static_cast<unsigned long long>(c->stats().global_updates) : 0ULL);
      std::fflush(stdout);
      window_s = window_max = window_cpu = 0.0;
    }
    return max_scans <= 0 || scans < max_scans;
  });
  const auto t_final = std::chrono::steady_clock::now();
  const double c_final = cpuSeconds();
  const std::size_t n = pipeline.ekf().numLandmarks();  // cekf: the last global update
  const double final_s = seconds(t_final), final_cpu = cpuSeconds() - c_final;
  // Drive time of the scans timed (from --start-at on): the real-time factors' denominator.
  const double drive = std::max(1e-9, sim_time - first_stamp + world.observation_period);
  std::printf("# scans %ld, simulated %.1f s (%.1f s timed), landmarks %zu\n", scans, sim_time,
              drive, n);
  std::printf(
      "# filter wall %.2f s (%.3f ms per scan, real-time factor %.3f), CPU %.2f s (%.3f ms per "
      "scan, real-time factor %.3f); final global update %.3f s wall, %.3f s CPU; wall incl. "
      "simulation %.1f s\n",
      filter_s, 1e3 * filter_s / std::max(1L, scans), filter_s / drive, filter_cpu,
      1e3 * filter_cpu / std::max(1L, scans), filter_cpu / drive, final_s, final_cpu,
      seconds(t_start));
  if (const CompressedEkf* c = pipeline.compressedEkf()) {
    const CompressedEkfStats& s = c->stats();
    std::printf(
        "# cekf: %llu areas (%llu compressed), %llu global updates (A grown %llu, "
        "landmark in reach %llu, pairing outside %llu, flushes %llu), %.2f s in global "
        "updates (%.1f GFLOP, %.2f GFLOP/s), largest active set %zu states\n",
        static_cast<unsigned long long>(s.phases),
        static_cast<unsigned long long>(s.compressed_phases),
        static_cast<unsigned long long>(s.global_updates), static_cast<unsigned long long>(s.grown),
        static_cast<unsigned long long>(s.landmark_in_reach),
        static_cast<unsigned long long>(s.pairing_outside),
        static_cast<unsigned long long>(s.flushes), s.global_update_s, 1e-9 * s.global_update_flops,
        s.global_update_s > 0 ? 1e-9 * s.global_update_flops / s.global_update_s : 0.0,
        s.max_active_states);
  }
  if (!o["--closures"].empty()) {
    // One row per global update: where the vehicle was, where its area opened, why it closed.
    std::ofstream csv(o["--closures"]);
    csv << "scan,drive_s,reason,x,y,yaw,opened_x,opened_y,opened_yaw,travelled_m,trigger_x,"
           "trigger_y,trigger_dist_m,opened_states,active_states,states,updates\n";
    for (std::size_t k = 0; k < closures.size(); ++k) {
      const CekfClosure& c = closures[k];
      const auto [scan, t] =
          k < closure_scan.size() ? closure_scan[k] : std::make_pair(scans, sim_time);
      csv << scan << ',' << t << ',' << toString(c.reason) << ',' << c.pose.x() << ',' << c.pose.y()
          << ',' << c.pose.z() << ',' << c.opened.x() << ',' << c.opened.y() << ',' << c.opened.z()
          << ',' << (c.pose.head<2>() - c.opened.head<2>()).norm() << ',' << c.trigger.x() << ','
          << c.trigger.y() << ',' << (c.trigger - c.pose.head<2>()).norm() << ',' << c.opened_states
          << ',' << c.active_states << ',' << c.states << ',' << c.updates << '\n';
    }
  }
  return 0;
}
