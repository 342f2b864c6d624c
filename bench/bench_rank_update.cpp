// Dense symmetric rank-d update P -= W W^T: GFLOP/s of this machine at a given size, the rate
// that sets the EKF update's floor in docs/benchmarks_vp.md (scripts/bench_vp.sh).
//
//   bench_rank_update [N d] [--repeat R]    (default: a grid of N = 250 .. 2000, d = 4 .. 16)
//   bench_rank_update --replay update_shapes.csv [--repeat R]
//                                           (a run's every update shape, ekf_slam_offline's output)
//
// Every variant is counted at N^2 d flops (a triangle-only update), so the rates compare times:
//   triangle  Eigen's selfadjointView<Lower>().rankUpdate (lower triangle only): the floor;
//   +mirror   the same plus a copy of the lower triangle onto the upper (the update before);
//   kernel    lowerRankDowndate (lower triangle in register tiles, what EkfSlam::update runs),
//             with the kernel the process picked (AVX2 where the CPU has it; the header says);
//   baseline  the same with the build's baseline kernel (SSE2 on x86-64): the same result;
//   invariant lowerProductDowndate with the invariant EKF's rank-2 re-expression in the same
//             pass (depth d + 2; jacobians: invariant, docs/consistency.md), still counted at
//             N^2 d: its rate against the kernel's is what the re-expression costs;
//   full      a plain product over the whole matrix (2 N^2 d flops done).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/symmetric_rank_update.h"

namespace {

using Clock = std::chrono::steady_clock;

// Best time of `repeat` runs of fn on a fresh copy of P0 (the copy is not timed).
template <typename Fn>
double bestSeconds(const Eigen::MatrixXd& P0, int repeat, Fn fn) {
  double best = 1e30;
  Eigen::MatrixXd P = P0;
  for (int r = 0; r < repeat; ++r) {
    P = P0;
    const auto t0 = Clock::now();
    fn(P);
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return best;
}

// The invariant EKF's operands for W: A = [W, u, v], B = [W, -v, -u] (P -= A B^T is the downdate
// plus u v^T + v u^T), u and v of the size the re-expression has.
void invariantOperands(const Eigen::MatrixXd& W, Eigen::MatrixXd* A, Eigen::MatrixXd* B) {
  const Eigen::Index n = W.rows(), d = W.cols();
  const Eigen::VectorXd u = Eigen::VectorXd::Random(n) * 0.01, v = Eigen::VectorXd::Random(n) * 0.1;
  A->resize(n, d + 2);
  B->resize(n, d + 2);
  *A << W, u, v;
  *B << W, -v, -u;
}

void run(Eigen::Index n, Eigen::Index d, int repeat) {
  // A well-scaled W (a downdate by W W^T of P = I + W W^T keeps P positive definite).
  const Eigen::MatrixXd W = Eigen::MatrixXd::Random(n, d) * 0.1;
  Eigen::MatrixXd P0 = W * W.transpose();
  P0.diagonal().array() += 1.0;
  const double flops = ekf_slam::rankDowndateFlops(n, d);
  const double tri = bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
    P.selfadjointView<Eigen::Lower>().rankUpdate(W, -1.0);
  });
  const double mir = bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
    P.selfadjointView<Eigen::Lower>().rankUpdate(W, -1.0);
    ekf_slam::mirrorLowerTriangle(ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)));
  });
  std::vector<double> workspace;  // kept between calls, as EkfSlam keeps it
  const double pan = bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
    ekf_slam::lowerRankDowndate(ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), W,
                                &workspace);
  });
  const ekf_slam::RankDowndateKernel picked = ekf_slam::rankDowndateKernel();
  ekf_slam::selectRankDowndateKernel(ekf_slam::RankDowndateKernel::kBaseline);
  const double base = bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
    ekf_slam::lowerRankDowndate(ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), W,
                                &workspace);
  });
  ekf_slam::selectRankDowndateKernel(picked);
  Eigen::MatrixXd A, B;
  invariantOperands(W, &A, &B);
  const double inv = bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
    ekf_slam::lowerProductDowndate(ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), A,
                                   B, &workspace);
  });
  const double full =
      bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) { P.noalias() -= W * W.transpose(); });
  std::printf("%6ld %4ld | %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f\n", static_cast<long>(n),
              static_cast<long>(d), flops / tri * 1e-9, flops / mir * 1e-9, flops / pan * 1e-9,
              flops / base * 1e-9, flops / inv * 1e-9, flops / full * 1e-9);
}

// The run's rank downdates alone: every shape (N, d) of `file` (n,d,updates) timed best of
// `repeat` for the triangle (the floor) and the kernel, times its count. Small d is memory-bound,
// so this floor at the run's exact sizes is above the one at its flop-weighted size.
int replay(const std::string& file, int repeat) {
  std::ifstream in(file);
  if (!in) {
    std::fprintf(stderr, "bench_rank_update: cannot read '%s'\n", file.c_str());
    return 2;
  }
  std::string line;
  std::getline(in, line);  // header
  double flops = 0.0, tri = 0.0, ker = 0.0, inv = 0.0;
  long updates = 0, shapes = 0;
  std::vector<double> workspace;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    long n = 0, d = 0, count = 0;
    char c1 = 0, c2 = 0;
    if (!(row >> n >> c1 >> d >> c2 >> count) || n <= 0 || d <= 0 || count <= 0) {
      std::fprintf(stderr, "bench_rank_update: bad row '%s' in %s\n", line.c_str(), file.c_str());
      return 2;
    }
    const Eigen::MatrixXd W = Eigen::MatrixXd::Random(n, d) * 0.1;
    Eigen::MatrixXd P0 = W * W.transpose();
    P0.diagonal().array() += 1.0;
    const double k = static_cast<double>(count);
    flops += k * ekf_slam::rankDowndateFlops(n, d);
    tri += k * bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
             P.selfadjointView<Eigen::Lower>().rankUpdate(W, -1.0);
           });
    ker += k * bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
             ekf_slam::lowerRankDowndate(
                 ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), W, &workspace);
           });
    Eigen::MatrixXd A, B;
    invariantOperands(W, &A, &B);
    inv += k * bestSeconds(P0, repeat, [&](Eigen::MatrixXd& P) {
             ekf_slam::lowerProductDowndate(
                 ekf_slam::MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), A, B, &workspace);
           });
    updates += count;
    ++shapes;
  }
  std::printf(
      "replay of %s: %ld updates in %ld shapes, %.3f GFLOP of rank downdates, best of %d, kernel "
      "%s\n",
      file.c_str(), updates, shapes, flops * 1e-9, repeat,
      ekf_slam::toString(ekf_slam::rankDowndateKernel()));
  std::printf("triangle (floor) %.3f s (%.2f GFLOP/s) | kernel %.3f s (%.2f GFLOP/s)\n", tri,
              flops / tri * 1e-9, ker, flops / ker * 1e-9);
  std::printf("invariant EKF's downdate (depth d + 2) %.3f s (%.2f GFLOP/s at N^2 d), %+.0f %%\n",
              inv, flops / inv * 1e-9, 100.0 * (inv / ker - 1.0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  int repeat = 30;
  std::string replay_file;
  std::vector<long> sizes;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--replay" && i + 1 < args.size()) {
      replay_file = args[++i];
    } else if (args[i] == "--repeat" && i + 1 < args.size()) {
      repeat = std::max(1, std::atoi(args[++i].c_str()));
    } else if (args[i] == "-h" || args[i] == "--help") {
      std::printf("usage: bench_rank_update [N d | --replay update_shapes.csv] [--repeat R]\n");
      return 0;
    } else {
      char* end = nullptr;
      const long v = std::strtol(args[i].c_str(), &end, 10);
      if (end == args[i].c_str() || *end != '\0' || v <= 0) {
        std::fprintf(stderr, "bench_rank_update: bad argument '%s' (N and d: positive)\n",
                     args[i].c_str());
        return 2;
      }
      sizes.push_back(v);
    }
  }
  if (!replay_file.empty()) return replay(replay_file, repeat);
  if (sizes.size() != 0 && sizes.size() != 2) {
    std::fprintf(stderr, "bench_rank_update: give both N and d, or neither\n");
    return 2;
  }
  std::printf("GFLOP/s at N^2 d flops, best of %d (Eigen %d.%d.%d, %s; kernel: %s)\n", repeat,
              EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION,
              Eigen::SimdInstructionSetsInUse(),
              ekf_slam::toString(ekf_slam::rankDowndateKernel()));
  std::printf("%6s %4s | %9s %9s %9s %9s %9s %9s\n", "N", "d", "triangle", "+mirror", "kernel",
              "baseline", "invariant", "full");
  if (sizes.size() == 2) {
    run(sizes[0], sizes[1], repeat);
    return 0;
  }
  for (long n : {250L, 500L, 1000L, 2000L}) {
    for (long d : {4L, 8L, 16L}) run(n, d, repeat);
  }
  return 0;
}
