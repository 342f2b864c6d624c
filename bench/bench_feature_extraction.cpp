// Feature extraction cost per scan (docs/feature_extraction.md, docs/benchmarks.md): each
// extractor and the scan filter chain on a synthetic 361-beam, 180 deg scan (0.5 deg) of a wall
// at 40 m with 20 cylinders, trunks and reflective beacons (intensities 5000 on the beacons, 200
// elsewhere). The scan is built outside the timed loop.
#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

namespace {

using ekf_slam::LaserScanData;

LaserScanData syntheticScan() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> range(3.0, 28.0), bearing(-1.4, 1.4), radius(0.05, 0.3);
  struct Cylinder {
    double x, y, r;
    float intensity;
  };
  std::vector<Cylinder> cylinders;
  for (int k = 0; k < 20; ++k) {
    const double d = range(rng), b = bearing(rng);
    cylinders.push_back({d * std::cos(b), d * std::sin(b), radius(rng), k % 2 ? 5000.0f : 200.0f});
  }
  LaserScanData s;
  s.angle_min = -M_PI / 2;
  s.angle_increment = M_PI / 360;
  s.range_max = 80.0;
  for (int i = 0; i <= 360; ++i) {
    const double a = s.angle_min + i * s.angle_increment, dx = std::cos(a), dy = std::sin(a);
    double best = 40.0;
    float intensity = 200.0f;
    for (const Cylinder& c : cylinders) {
      const double along = c.x * dx + c.y * dy, d2 = c.x * c.x + c.y * c.y - along * along;
      if (along <= 0.0 || d2 > c.r * c.r) continue;
      const double t = along - std::sqrt(c.r * c.r - d2);
      if (t < best) {
        best = t;
        intensity = c.intensity;
      }
    }
    s.ranges.push_back(static_cast<float>(best));
    s.intensities.push_back(intensity);
  }
  return s;
}

void run(benchmark::State& state, const ekf_slam::FeatureExtractor& e) {
  const LaserScanData scan = syntheticScan();
  std::size_t found = 0;
  for (auto _ : state) {
    const auto obs = e.extract(scan);
    found = obs.size();
    benchmark::DoNotOptimize(obs.data());
  }
  state.counters["observations"] = static_cast<double>(found);
}

void BM_TreeExtractor(benchmark::State& state) { run(state, ekf_slam::TreeFeatureExtractor()); }
void BM_BeaconExtractor(benchmark::State& state) {
  ekf_slam::BeaconExtractorParams p;
  p.beacon_radius = 0.1;
  p.max_width = 0.7;
  run(state, ekf_slam::BeaconExtractor(p));
}

// The four filters, as a vehicle mask, a field-of-view crop, range and intensity bounds.
void BM_ScanFilterChain(benchmark::State& state) {
  const auto chain = ekf_slam::ScanFilterChain::fromSpecs(
      {{"range", "laser_filters/LaserScanRangeFilter", {{"upper_threshold", "30"}}},
       {"fov",
        "laser_filters/LaserScanAngularBoundsFilterInPlace",
        {{"lower_angle", "-1.4"}, {"upper_angle", "1.4"}}},
       {"intensity", "laser_filters/LaserScanIntensityFilter", {{"lower_threshold", "100"}}},
       {"box",
        "laser_filters/LaserScanBoxFilter",
        {{"min_x", "-1"}, {"max_x", "4"}, {"min_y", "-1"}, {"max_y", "1"}}}});
  const LaserScanData scan = syntheticScan();
  LaserScanData work;
  for (auto _ : state) {
    work = scan;  // as the pipeline does: filter a copy
    chain.apply(&work, Eigen::Vector3d(3.78, 0.5, 0.0));
    benchmark::DoNotOptimize(work.ranges.data());
  }
}

}  // namespace

BENCHMARK(BM_TreeExtractor);
BENCHMARK(BM_BeaconExtractor);
BENCHMARK(BM_ScanFilterChain);
BENCHMARK_MAIN();
