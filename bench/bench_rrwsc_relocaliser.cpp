// The RRW&SC relocaliser on seed 004's kidnapping: for each rrw_kidnap_K world and seed, the
// first observation set after the kidnap (t = 30 s) is relocalised against the map without a
// prior. The map is the world's true landmark layout with a 0.3 m standard deviation, standing in
// for the EKF map the pipeline would pass (the map is complete long before the kidnap: every
// landmark is in view from the start). Prints, per K, how often the answer is kFound within 1 m
// and 0.05 rad of the true pose, wrong (kFound farther off), ambiguous or not found, and the time
// per call. Usage: bench_rrwsc_relocaliser [runs per K, default 20]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

int main(int argc, char** argv) {
  using namespace ekf_slam;
  const int runs = argc > 1 ? std::atoi(argv[1]) : 20;
  std::printf(
      "| K | kidnap [m] | found within 1 m | found, wrong | ambiguous | not found | median error "
      "[m] | time per call [ms] |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (int k = 1; k <= 10; ++k) {
    const sim::World world = sim::makeWorld("rrw_kidnap_" + std::to_string(k));
    std::vector<MapLandmark> map;
    for (std::size_t j = 0; j < world.landmarks.size(); ++j) {
      MapLandmark l;
      l.id = static_cast<LandmarkId>(j);
      l.position = world.landmarks[j];
      l.covariance = 0.09 * Eigen::Matrix2d::Identity();
      map.push_back(l);
    }
    RRWSCRelocaliser reloc;
    reloc.configure(MapParameterSource());
    reloc.setMap(map);
    int good = 0, wrong = 0, ambiguous = 0, not_found = 0;
    double ms = 0.0;
    std::vector<double> errors;
    for (int seed = 1; seed <= runs; ++seed) {
      sim::Simulation s(world, seed);
      for (auto e = s.next(); e != sim::Simulation::Event::kEnd; e = s.next()) {
        if (e != sim::Simulation::Event::kObservations) continue;
        const sim::ObservationSet& z = s.observations();
        if (z.stamp < world.kidnaps.front().time) continue;
        const auto t0 = std::chrono::steady_clock::now();
        const RelocalisationResult r =
            reloc.relocalise(z.toObservations(), world.sensor.offset, nullptr);
        ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                  .count();
        if (r.status == RelocalisationStatus::kAmbiguous) {
          ++ambiguous;
        } else if (r.status == RelocalisationStatus::kNotFound) {
          ++not_found;
        } else {
          const double error = (r.pose.head<2>() - z.true_pose.head<2>()).norm();
          errors.push_back(error);
          const bool ok = error < 1.0 && std::abs(wrapAngle(r.pose.z() - z.true_pose.z())) < 0.05;
          ++(ok ? good : wrong);
        }
        break;
      }
    }
    std::sort(errors.begin(), errors.end());
    std::printf("| %d | %.1f | %d/%d | %d | %d | %d | %.2f | %.2f |\n", k, 4.6 * k, good, runs,
                wrong, ambiguous, not_found, errors.empty() ? NAN : errors[errors.size() / 2],
                ms / runs);
  }
  return 0;
}
