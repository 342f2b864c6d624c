// Lower-triangle rank-d downdate in column panels.
#include "ekf_slam/core/filter/symmetric_rank_update.h"

#include <algorithm>

namespace ekf_slam {

namespace {

// Panel width: wide enough for Eigen's product kernel to run at speed.
constexpr Eigen::Index kPanel = 128;
// Rows per product: Eigen packs the left operand (rows x d) on the stack up to
// EIGEN_STACK_ALLOCATION_LIMIT (128 KiB), on the heap above it.
constexpr Eigen::Index kPackDoubles = 12 * 1024;

}  // namespace

void lowerRankDowndate(MatrixView P, const Eigen::Ref<const Eigen::MatrixXd>& W) {
  const Eigen::Index n = P.rows();
  const Eigen::Index d = W.cols();
  if (n == 0 || d == 0) return;
  const Eigen::Index chunk = std::max<Eigen::Index>(kPanel, kPackDoubles / d);
  for (Eigen::Index j = 0; j < n; j += kPanel) {
    const Eigen::Index b = std::min(kPanel, n - j);
    const auto Wj = W.middleRows(j, b);
    P.block(j, j, b, b).selfadjointView<Eigen::Lower>().rankUpdate(Wj, -1.0);
    for (Eigen::Index i = j + b; i < n; i += chunk) {
      const Eigen::Index r = std::min(chunk, n - i);
      P.block(i, j, r, b).noalias() -= W.middleRows(i, r) * Wj.transpose();
    }
  }
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
