// Association benchmark: every associator (constructed directly, ROS-free) on random scans of
// maps of growing size at a fixed landmark density, so that the sensor sees a similar handful of
// landmarks whatever the map size. Times associate() including the AssociationContext
// construction; the problem setup is outside the timed loop. scripts/bench_association.sh runs it
// and docs/benchmarks.md has the results.
//
// Map sizes: the EKF keeps a dense (3 + 2n)^2 covariance, so n = 100000 would need 320 GB (80 GB
// even for a float triangle) and cannot be built; the largest size run is 10000 (3.2 GB, only
// when MemAvailable allows), which already shows whether the cost grows with the map.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <benchmark/benchmark.h>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/jcbb.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/association/rrwsc.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"

namespace ekf_slam {
namespace {

constexpr double kAreaPerLandmark = 400.0;  // [m^2]: one tree per 400 m^2, as in Victoria Park
constexpr double kClutterShare = 0.2;       // share of the observations that are clutter
constexpr int kScans = 8;                   // different scans cycled through per benchmark
// Pose uncertainty: a part correlated with the map (the map was built from that pose) and a
// free part (odometry drift since), as a SLAM filter has it between two scans.
const Eigen::Vector3d kPoseSigmaCorrelated(0.3, 0.3, deg2rad(1.0));
const Eigen::Vector3d kPoseSigmaFree(0.2, 0.2, deg2rad(0.5));
constexpr double kLandmarkSigma = 0.1;    // independent map error [m]
constexpr double kCorrelatedRadius = 80;  // landmarks this close share the pose error [m]
const Eigen::Vector2d kNoiseSigma(0.1, deg2rad(1.0));  // range [m], bearing [rad]

/// One map (EKF state) and a few scans of it from the same estimated pose.
struct Problem {
  EkfSlam ekf;
  LandmarkIndex index;
  RangeBearingModel model;
  double sensor_range = 0.0;
  std::vector<std::vector<Observation>> scans;
  std::vector<std::vector<int>> truth;  ///< per scan, per observation: landmark index or -1
};

Eigen::Vector2d sampleNormal2(std::mt19937_64& rng, const Eigen::Vector2d& sigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  return {sigma.x() * n(rng), sigma.y() * n(rng)};
}

/// `free_scale` multiplies the free pose error (odometry drift since the map was last seen).
std::unique_ptr<Problem> makeProblem(int num_landmarks, int num_obs, double free_scale,
                                     std::uint64_t seed) {
  auto pb = std::make_unique<Problem>();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);

  // Map: uniform over a square centred on the vehicle whose area grows with n.
  const double side = std::sqrt(kAreaPerLandmark * num_landmarks);
  std::vector<Eigen::Vector2d> truth(num_landmarks);
  for (auto& m : truth) m = {side * (unit(rng) - 0.5), side * (unit(rng) - 0.5)};
  const Eigen::Vector3d true_pose(0.0, 0.0, 2.0 * M_PI * unit(rng));
  // Range that holds (1 - clutter) * m landmarks on average over the full circle.
  pb->sensor_range = std::sqrt((1.0 - kClutterShare) * num_obs * kAreaPerLandmark / M_PI);

  // Estimate: x_hat = x + A dc + df (landmarks near the pose share the correlated error dc).
  Eigen::Vector3d dc, df;
  for (int k = 0; k < 3; ++k) {
    dc(k) = kPoseSigmaCorrelated(k) * normal(rng);
    df(k) = free_scale * kPoseSigmaFree(k) * normal(rng);
  }
  const int dim = 3 + 2 * num_landmarks;
  Eigen::VectorXd mean(dim);
  mean.head<3>() = true_pose + dc + df;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(dim, dim);
  const Eigen::Matrix3d Pc = kPoseSigmaCorrelated.array().square().matrix().asDiagonal();
  const Eigen::Matrix3d Pf = (free_scale * kPoseSigmaFree).array().square().matrix().asDiagonal();
  P.topLeftCorner<3, 3>() = Pc + Pf;
  std::vector<int> correlated;
  std::vector<Matrix23d> A(num_landmarks, Matrix23d::Zero());
  for (int j = 0; j < num_landmarks; ++j) {
    const int r = pb->ekf.stateRow(j);
    Eigen::Vector2d err = sampleNormal2(rng, Eigen::Vector2d::Constant(kLandmarkSigma));
    if ((truth[j] - true_pose.head<2>()).norm() < kCorrelatedRadius) {
      // d m / d pose of a landmark fixed relative to the vehicle.
      const Eigen::Vector2d d = truth[j] - true_pose.head<2>();
      A[j] << 1.0, 0.0, -d.y(), 0.0, 1.0, d.x();
      err += A[j] * dc;
      correlated.push_back(j);
    }
    mean.segment<2>(r) = truth[j] + err;
    P.block<2, 2>(r, r).diagonal().setConstant(kLandmarkSigma * kLandmarkSigma);
  }
  for (int a : correlated) {
    const int ra = pb->ekf.stateRow(a);
    const Eigen::Matrix<double, 2, 3> APc = A[a] * Pc;
    P.block<2, 3>(ra, 0) = APc;
    P.block<3, 2>(0, ra) = APc.transpose();
    for (int b : correlated) P.block<2, 2>(ra, pb->ekf.stateRow(b)) += APc * A[b].transpose();
  }
  std::vector<LandmarkId> ids(num_landmarks);
  for (int j = 0; j < num_landmarks; ++j) ids[j] = j;
  pb->ekf.setState(mean, P, ids);
  P.resize(0, 0);
  pb->index.sync(pb->ekf);

  // Scans: the visible landmarks (nearest first, at most (1 - clutter) m of them) with noise,
  // clutter up to m observations, in random order.
  std::vector<int> visible;
  for (int j = 0; j < num_landmarks; ++j) {
    if ((truth[j] - true_pose.head<2>()).norm() < pb->sensor_range) visible.push_back(j);
  }
  std::sort(visible.begin(), visible.end(), [&](int a, int b) {
    return (truth[a] - true_pose.head<2>()).norm() < (truth[b] - true_pose.head<2>()).norm();
  });
  const int real = std::min<int>(visible.size(), std::lround((1.0 - kClutterShare) * num_obs));
  const Eigen::Matrix2d R = kNoiseSigma.array().square().matrix().asDiagonal();
  for (int s = 0; s < kScans; ++s) {
    std::vector<std::pair<Observation, int>> scan;
    for (int k = 0; k < real; ++k) {
      Observation o;
      o.z = pb->model.predict(true_pose, truth[visible[k]]) + sampleNormal2(rng, kNoiseSigma);
      o.z.y() = wrapAngle(o.z.y());
      o.R = R;
      scan.emplace_back(o, visible[k]);
    }
    while (static_cast<int>(scan.size()) < num_obs) {
      Observation o;
      o.z = {pb->sensor_range * std::sqrt(unit(rng)), M_PI * (2.0 * unit(rng) - 1.0)};
      o.R = R;
      scan.emplace_back(o, -1);
    }
    std::shuffle(scan.begin(), scan.end(), rng);
    pb->scans.emplace_back();
    pb->truth.emplace_back();
    for (const auto& [o, j] : scan) {
      pb->scans.back().push_back(o);
      pb->truth.back().push_back(j);
    }
  }
  return pb;
}

using Factory = std::function<std::unique_ptr<DataAssociation>(const Problem&)>;

void runBenchmark(benchmark::State& state, const Factory& factory, int num_landmarks, int num_obs,
                  double free_scale) {
  // Google Benchmark calls this function several times while it picks the iteration count, and
  // the associators of one size run one after the other: keep the last problem.
  static std::unique_ptr<Problem> cached;
  static std::tuple<int, int, double> cached_key;
  const auto key = std::make_tuple(num_landmarks, num_obs, free_scale);
  if (!cached || cached_key != key) {
    cached.reset();  // free the old covariance first
    cached = makeProblem(num_landmarks, num_obs, free_scale, 1000 * num_landmarks + num_obs);
    cached_key = key;
  }
  const Problem* pb = cached.get();
  auto assoc = factory(*pb);

  // Untimed pass: correctness and work counters of the scans being timed.
  double correct = 0.0, evaluations = 0.0, nodes = 0.0, inexact = 0.0;
  for (int s = 0; s < kScans; ++s) {
    const AssociationContext ctx(pb->ekf, pb->model, pb->index, pb->scans[s], s);
    const AssociationResult r = assoc->associate(ctx);
    for (int i = 0; i < num_obs; ++i) {
      const bool paired = r.decision[i] == Decision::kPaired;
      const int truth = pb->truth[s][i];
      correct += paired ? (truth >= 0 && r.landmark[i] == truth) : truth < 0;
    }
    evaluations += ctx.evaluations();
    // JCBB is exact unless its node budget ran out: count the scans where it did.
    if (const auto* j = dynamic_cast<const JCBB*>(assoc.get())) {
      nodes += j->lastStats().nodes;
      inexact += j->lastStats().budget_exhausted;
    } else if (const auto* h = dynamic_cast<const NNJCBB*>(assoc.get())) {
      nodes += h->lastRanJcbb() ? h->lastStats().nodes : 0;
      inexact += h->lastRanJcbb() && h->lastStats().budget_exhausted;
    }
  }
  assoc->reset();

  int s = 0;
  double stamp = 0.0;
  for (auto _ : state) {
    const AssociationContext ctx(pb->ekf, pb->model, pb->index, pb->scans[s], stamp);
    AssociationResult r = assoc->associate(ctx);
    benchmark::DoNotOptimize(r);
    s = (s + 1) % kScans;
    stamp += 0.2;
  }
  state.counters["correct"] = correct / (kScans * num_obs);
  state.counters["evals"] = evaluations / kScans;
  state.counters["range_m"] = pb->sensor_range;
  state.counters["jcbb_nodes"] = nodes / kScans;
  state.counters["budget_hit"] = inexact;
}

/// Does nothing: times the AssociationContext construction (and the call) alone.
class ContextOnly : public DataAssociation {
 public:
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "ContextOnly"; }
  AssociationResult associate(const AssociationContext& ctx) override {
    AssociationResult r;
    r.resize(ctx.numObservations());
    return r;
  }
  void reset() override {}
};

template <typename T>
Factory plain() {
  return [](const Problem&) { return std::make_unique<T>(); };
}

/// An associator configured with the given parameters.
template <typename T>
Factory configured(std::map<std::string, std::string> params) {
  return [params](const Problem&) {
    auto a = std::make_unique<T>();
    a->configure(MapParameterSource(params));
    return std::unique_ptr<DataAssociation>(std::move(a));
  };
}

long memAvailableBytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  long kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit) {
    if (key == "MemAvailable:") return kb * 1024;
  }
  return 0;
}

void registerAll() {
  // DJNN's local region (eq. 10) must cover the sensor's range, and the scan covers 360 deg.
  const Factory djnn = [](const Problem& pb) {
    auto d = std::make_unique<DJNN>();
    MapParameterSource p;
    p.set("sensor_range", std::to_string(pb.sensor_range + 2.0));
    p.set("field_of_view", std::to_string(2.0 * M_PI));
    d->configure(p);
    return std::unique_ptr<DataAssociation>(std::move(d));
  };
  const std::vector<std::pair<std::string, Factory>> associators = {
      {"DJNN", djnn},
      {"NN", plain<NN>()},
      {"JCBB", plain<JCBB>()},
      {"NNJCBB", plain<NNJCBB>()},
      {"Hungarian", plain<Hungarian>()},
      {"RRWSC", configured<RRWSC>({})},
      {"ContextOnly", plain<ContextOnly>()}};
  std::vector<int> sizes = {100, 1000};
  // Dense covariance of 10000 landmarks: 3.2 GB, held twice while the problem is set up.
  const long need = 2L * 8L * 20003L * 20003L + (1L << 30);
  if (memAvailableBytes() > need) {
    sizes.push_back(10000);
  } else {
    std::cerr << "bench_association: skipping n = 10000 (needs " << need / (1L << 30)
              << " GB available)\n";
  }
  std::cerr << "bench_association: n = 100000 is not run: the dense EKF covariance would take "
               "320 GB\n";
  // Ordinary pose error at every size; a drift 5 times larger (1 m, 2.5 deg) at 1000 landmarks,
  // where gates overlap and JCBB has to search.
  std::vector<std::pair<int, double>> cases;
  for (int n : sizes) cases.emplace_back(n, 1.0);
  cases.emplace_back(1000, 5.0);
  for (const auto& [n, scale] : cases) {
    for (int m : {5, 10, 20}) {
      for (const auto& [name, factory] : associators) {
        const std::string bench = name + "/landmarks:" + std::to_string(n) +
                                  "/obs:" + std::to_string(m) +
                                  (scale > 1.0 ? "/drift:x" + std::to_string(int(scale)) : "");
        benchmark::RegisterBenchmark(bench.c_str(), [factory = factory, n = n, m,
                                                     scale = scale](benchmark::State& st) {
          runBenchmark(st, factory, n, m, scale);
        })->Unit(benchmark::kMicrosecond);
      }
    }
  }
  // Seed 004's setting: the robot sees the whole map (every landmark is a candidate: a margin
  // wider than the map), 30 observations (20 % clutter) against 60 and 120 landmarks; the gated
  // associators for comparison.
  const std::map<std::string, std::string> whole = {{"candidate_margin", "1000"}};
  for (int n : {60, 120}) {
    for (const auto& [name, factory] :
         std::vector<std::pair<std::string, Factory>>{{"RRWSC", configured<RRWSC>(whole)},
                                                      {"Hungarian", configured<Hungarian>(whole)},
                                                      {"NN", configured<NN>(whole)}}) {
      const std::string bench = name + "/whole_map/landmarks:" + std::to_string(n) + "/obs:30";
      benchmark::RegisterBenchmark(bench.c_str(), [factory = factory, n](benchmark::State& st) {
        runBenchmark(st, factory, n, 30, 1.0);
      })->Unit(benchmark::kMicrosecond);
    }
  }
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  ekf_slam::registerAll();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
