// Rank-d downdate P -= W W^T of the lower triangle of a dense symmetric matrix, for the EKF's
// covariance update (docs/benchmarks_vp.md). ROS-free (Eigen only).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

/// A column-major view with a leading dimension of its own: the covariance lives in the top-left
/// corner of a larger buffer so that it can grow without reallocating.
using MatrixView = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using ConstMatrixView = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

/// The kernels the downdates below can run. They give the same result to the bit (each element
/// adds its d products in the same order, and none contracts them into FMA); they differ in
/// speed: AVX2's 4-lane vectors run the Victoria Park update about 1.6x faster than SSE2's 2
/// (docs/benchmarks_vp.md).
enum class RankDowndateKernel : std::uint8_t {
  kBaseline = 0,  ///< the build's own vector width: SSE2 on x86-64, AVX under EKF_SLAM_NATIVE
  kAvx2 = 1,      ///< x86-64 builds without EKF_SLAM_NATIVE, on CPUs that report AVX2
};
const char* toString(RankDowndateKernel kernel);  ///< "baseline", "avx2"
/// Whether this build and this CPU can run the kernel.
bool rankDowndateKernelAvailable(RankDowndateKernel kernel);
/// The kernel in use: AVX2 where available, unless the environment sets
/// EKF_SLAM_PORTABLE_KERNEL (non-empty and not "0") when the process first asks.
RankDowndateKernel rankDowndateKernel();
/// Selects the kernel for the whole process (tests, benchmarks); false, and nothing changes, when
/// it is not available.
bool selectRankDowndateKernel(RankDowndateKernel kernel);

/// P -= W W^T on the lower triangle (diagonal included) of an N x N P, W N x d; the strict upper
/// triangle is not touched. N^2 d flops, in register tiles of its own (faster here than Eigen's
/// triangular product, docs/benchmarks_vp.md). W is first copied into `workspace` (grown when too
/// small, never shrunk: no heap allocation once it has reached the largest N; a temporary when
/// null).
void lowerRankDowndate(MatrixView P, const Eigen::Ref<const Eigen::MatrixXd>& W,
                       std::vector<double>* workspace = nullptr);

/// P -= A B^T on the lower triangle, A and B N x d with A B^T symmetric (the caller's promise:
/// only the lower triangle is computed), in the same kernel: e.g. a downdate and a symmetric
/// rank-2 term u v^T + v u^T in one pass over P, with A = [W, u, v] and B = [W, -v, -u].
void lowerProductDowndate(MatrixView P, const Eigen::Ref<const Eigen::MatrixXd>& A,
                          const Eigen::Ref<const Eigen::MatrixXd>& B,
                          std::vector<double>* workspace = nullptr);

/// Copies the strict lower triangle of P onto the upper one (tiled so that the strided reads stay
/// in cache): completes P after lowerRankDowndate.
void mirrorLowerTriangle(MatrixView P);

/// Flops of that downdate (N^2 d).
inline double rankDowndateFlops(Eigen::Index n, Eigen::Index d) {
  return static_cast<double>(n) * static_cast<double>(n) * static_cast<double>(d);
}

}  // namespace ekf_slam
