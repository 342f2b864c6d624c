// Lower-triangle rank-d downdate with a register-tiled kernel of its own
// (rank_downdate_kernel.h), at the build's vector width or, where the CPU has it, with AVX2.
#include "ekf_slam/core/filter/symmetric_rank_update.h"

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <string>
#include <vector>

#if defined(__AVX__)
#define EKF_SLAM_KERNEL_LANES 4
#else
#define EKF_SLAM_KERNEL_LANES 2
#endif
#define EKF_SLAM_KERNEL_NAMESPACE baseline_kernel
#include "rank_downdate_kernel.h"

namespace ekf_slam {

namespace avx2_kernel {
// symmetric_rank_update_avx2.cpp (compiled only where EKF_SLAM_AVX2_KERNEL is defined).
std::ptrdiff_t packedSize(std::ptrdiff_t n, std::ptrdiff_t d);
void productDowndate(double* p, std::ptrdiff_t ld, std::ptrdiff_t n, const double* A_data,
                     std::ptrdiff_t lda, const double* B_data, std::ptrdiff_t ldb, std::ptrdiff_t d,
                     double* packed);
}  // namespace avx2_kernel

namespace {

bool cpuHasAvx2() {
#if defined(EKF_SLAM_AVX2_KERNEL)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

RankDowndateKernel initialKernel() {
  const char* portable = std::getenv("EKF_SLAM_PORTABLE_KERNEL");
  if (portable && *portable && std::string(portable) != "0") return RankDowndateKernel::kBaseline;
  return cpuHasAvx2() ? RankDowndateKernel::kAvx2 : RankDowndateKernel::kBaseline;
}

std::atomic<RankDowndateKernel>& selected() {
  static std::atomic<RankDowndateKernel> kernel{initialKernel()};
  return kernel;
}

}  // namespace

const char* toString(RankDowndateKernel kernel) {
  return kernel == RankDowndateKernel::kAvx2 ? "avx2" : "baseline";
}

bool rankDowndateKernelAvailable(RankDowndateKernel kernel) {
  return kernel == RankDowndateKernel::kBaseline || cpuHasAvx2();
}

RankDowndateKernel rankDowndateKernel() { return selected().load(std::memory_order_relaxed); }

bool selectRankDowndateKernel(RankDowndateKernel kernel) {
  if (!rankDowndateKernelAvailable(kernel)) return false;
  selected().store(kernel, std::memory_order_relaxed);
  return true;
}

void lowerRankDowndate(MatrixView P, const Eigen::Ref<const Eigen::MatrixXd>& W,
                       std::vector<double>* workspace) {
  lowerProductDowndate(P, W, W, workspace);
}

void lowerProductDowndate(MatrixView P, const Eigen::Ref<const Eigen::MatrixXd>& A,
                          const Eigen::Ref<const Eigen::MatrixXd>& B,
                          std::vector<double>* workspace) {
  const Eigen::Index n = P.rows();
  const Eigen::Index d = A.cols();
  if (n == 0 || d == 0) return;
  std::vector<double> local;
  std::vector<double>& packed = workspace ? *workspace : local;
  // The kernel's two entry points, from the file compiled for it.
  auto packed_size = &baseline_kernel::packedSize;
  auto downdate = &baseline_kernel::productDowndate;
#if defined(EKF_SLAM_AVX2_KERNEL)
  if (rankDowndateKernel() == RankDowndateKernel::kAvx2) {
    packed_size = &avx2_kernel::packedSize;
    downdate = &avx2_kernel::productDowndate;
  }
#endif
  const auto size = static_cast<std::size_t>(packed_size(n, d));
  if (packed.size() < size) packed.resize(size);
  downdate(P.data(), P.outerStride(), n, A.data(), A.outerStride(), B.data(), B.outerStride(), d,
           packed.data());
}

void mirrorLowerTriangle(MatrixView P) {
  constexpr Eigen::Index kTile = 32;
  const Eigen::Index n = P.rows(), ld = P.outerStride();
  double* d = P.data();
  for (Eigen::Index jb = 0; jb < n; jb += kTile) {
    const Eigen::Index je = std::min(jb + kTile, n);
    for (Eigen::Index ib = 0; ib <= jb; ib += kTile) {
      for (Eigen::Index j = jb; j < je; ++j) {
        double* col = d + j * ld;
        const Eigen::Index ie = std::min(ib + kTile, j);
        for (Eigen::Index i = ib; i < ie; ++i) col[i] = d[i * ld + j];
      }
    }
  }
}

}  // namespace ekf_slam
