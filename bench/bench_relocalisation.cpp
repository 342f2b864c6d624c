// Relocalisation benchmark: FGCBB against GCBB (seed 001 paper 2, figure 4) on random forests at
// Victoria Park's density (one tree per 400 m^2), by number of observations m (the scan sees
// the m nearest trees within R = 16 m of a random pose, no prior) and by map size n. Times one
// relocalise() call; setMap() (the pair table) is outside the timed loop. The rows whose forest
// has fewer than m trees in range are skipped. docs/benchmarks.md has the results.
//   bench_relocalisation [--benchmark_filter=FGCBB]
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/core/relocalisation/gcbb.h"

namespace ekf_slam {
namespace {

constexpr double kAreaPerLandmark = 150.0;  // [m^2]: dense enough that 16 m shows up to 14 trees
constexpr int kScans = 8;                   // different poses cycled through per benchmark

struct Problem {
  std::vector<MapLandmark> map;
  std::vector<std::vector<Observation>> scans;
};

Problem makeProblem(int n, int m) {
  std::mt19937 rng(static_cast<unsigned>(1000 * n + m));
  const double side = std::sqrt(kAreaPerLandmark * n);
  std::uniform_real_distribution<double> u(0.0, side);
  std::normal_distribution<double> g(0.0, 1.0);
  Problem p;
  for (int j = 0; j < n; ++j) {
    MapLandmark l;
    l.id = j;
    l.position = Eigen::Vector2d(u(rng), u(rng));
    l.covariance = Eigen::Matrix2d::Identity() * 0.04;
    p.map.push_back(l);
  }
  const RangeBearingModel model;
  for (int tries = 0; tries < 1000 && static_cast<int>(p.scans.size()) < kScans; ++tries) {
    const Eigen::Vector3d pose(u(rng), u(rng), M_PI * (2.0 * u(rng) / side - 1.0));
    std::vector<std::pair<double, Observation>> seen;
    for (const MapLandmark& l : p.map) {
      Observation o;
      o.z = model.predict(pose, l.position);
      if (o.z.x() > 16.0) continue;
      o.z += Eigen::Vector2d(0.1 * g(rng), 0.01 * g(rng));
      o.R = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
      seen.emplace_back(o.z.x(), o);
    }
    if (static_cast<int>(seen.size()) < m) continue;
    std::sort(seen.begin(), seen.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Observation> scan;
    for (int i = 0; i < m; ++i) scan.push_back(seen[i].second);
    p.scans.push_back(scan);
  }
  return p;
}

template <class Algorithm>
void relocalise(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int m = static_cast<int>(state.range(1));
  const Problem p = makeProblem(n, m);
  if (p.scans.empty()) {
    state.SkipWithError("no pose sees that many trees");
    return;
  }
  Algorithm algorithm;
  algorithm.setMap(p.map);
  std::size_t k = 0, found = 0, calls = 0;
  for (auto _ : state) {
    const RelocalisationResult r =
        algorithm.relocalise(p.scans[k++ % p.scans.size()], Eigen::Vector3d::Zero(), nullptr);
    benchmark::DoNotOptimize(r.pose);
    found += r.status == RelocalisationStatus::kFound;
    ++calls;
  }
  state.counters["found"] = static_cast<double>(found) / static_cast<double>(calls);
}

void args(benchmark::internal::Benchmark* b) {
  for (const int n : {100, 1000}) {
    for (const int m : {4, 6, 8, 10, 12, 14}) b->Args({n, m});
  }
}

BENCHMARK_TEMPLATE(relocalise, FGCBB)->Apply(args)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(relocalise, GCBB)->Apply(args)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace ekf_slam

BENCHMARK_MAIN();
