// Lower-triangle rank-d downdate with a register-tiled kernel of its own.
#include "ekf_slam/core/filter/symmetric_rank_update.h"

#include <algorithm>
#include <vector>

namespace ekf_slam {

namespace {

// The widest double vector the build targets: 4 with AVX (-DEKF_SLAM_NATIVE=ON on this CPU),
// else SSE2's 2. GCC/Clang vector extensions, so that the compiler picks the instructions (and
// contracts a * b + c into FMA where the target has it).
#if defined(__AVX__)
constexpr int kLanes = 4;
#else
constexpr int kLanes = 2;
#endif
typedef double Vec __attribute__((vector_size(kLanes * sizeof(double))));
// Same, for loads and stores at any double-aligned address (P, A and B have leading dimensions of
// any size).
typedef double VecU __attribute__((vector_size(kLanes * sizeof(double)), aligned(sizeof(double))));

// Register tile: kRows x kCols of P, 12 SSE2 or 8 AVX accumulators (with the operands, within the
// 16 vector registers). The shapes are the fastest measured here (bench_rank_update): 6 x 4 with
// SSE2, 4 x 8 with AVX2 + FMA.
constexpr int kRowVecs = kLanes == 2 ? 3 : 1;
constexpr int kRows = kRowVecs * kLanes;
constexpr int kCols = kLanes == 2 ? 4 : 8;
// A's and B's columns per pass: the broadcast copies of a column block (kDepth x kCols vectors)
// stay on the stack (32 KiB with AVX) and in L1. Updates of larger d make several passes.
constexpr int kDepth = 128;

inline Vec load(const double* p) { return *reinterpret_cast<const VecU*>(p); }
inline void store(double* p, Vec v) { *reinterpret_cast<VecU*>(p) = v; }

// P(i0.., j0..) -= A(i0.., 0..d) B(j0.., 0..d)^T for one tile. `a` holds the tile's rows of A,
// k-major (a[k * kRows + r], zero below row n); `b` holds B(j0 + c, k) broadcast at
// b[k * kCols + c]. Full tiles strictly below the diagonal go through vectors; tiles on the
// diagonal or at the bottom edge store element by element (the lower triangle, rows below n).
inline void tile(double* P, Eigen::Index ld, const double* a, Eigen::Index d, const Vec* b,
                 Eigen::Index i0, Eigen::Index j0, Eigen::Index n, int cols) {
  Vec acc[kRowVecs][kCols] = {};
  for (Eigen::Index k = 0; k < d; ++k, a += kRows) {
    const Vec* bk = b + k * kCols;
#pragma GCC unroll 4
    for (int r = 0; r < kRowVecs; ++r) {
      const Vec ar = load(a + r * kLanes);
#pragma GCC unroll 8
      for (int c = 0; c < kCols; ++c) acc[r][c] += ar * bk[c];
    }
  }
  const Eigen::Index rows = std::min<Eigen::Index>(kRows, n - i0);
  if (rows == kRows && cols == kCols && i0 >= j0 + kCols) {
#pragma GCC unroll 8
    for (int c = 0; c < kCols; ++c) {
      double* p = P + (j0 + c) * ld + i0;
#pragma GCC unroll 4
      for (int r = 0; r < kRowVecs; ++r) store(p + r * kLanes, load(p + r * kLanes) - acc[r][c]);
    }
    return;
  }
  for (int c = 0; c < cols; ++c) {
    double* p = P + (j0 + c) * ld;
    for (Eigen::Index i = std::max(i0, j0 + c); i < i0 + rows; ++i) {
      const Eigen::Index r = i - i0;
      p[i] -= acc[r / kLanes][c][r % kLanes];
    }
  }
}

}  // namespace

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
  const Eigen::Index blocks = (n + kRows - 1) / kRows;
  const Eigen::Index depth_max = std::min<Eigen::Index>(kDepth, d);
  if (packed.size() < static_cast<std::size_t>(blocks * kRows * depth_max))
    packed.resize(blocks * kRows * depth_max);
  double* p = P.data();
  const Eigen::Index ld = P.outerStride(), lda = A.outerStride(), ldb = B.outerStride();
  Vec b[kDepth * kCols];
  for (Eigen::Index k0 = 0; k0 < d; k0 += kDepth) {
    const Eigen::Index depth = std::min<Eigen::Index>(kDepth, d - k0);
    const double* wa = A.data() + k0 * lda;
    const double* wb = B.data() + k0 * ldb;
    // A's rows in tiles, k-major within a tile: the kernel then reads one stream (O(n d), against
    // the downdate's n^2 d / 2 multiply-adds).
    for (Eigen::Index t = 0; t < blocks; ++t) {
      double* a = packed.data() + t * kRows * depth;
      const Eigen::Index i0 = t * kRows, rows = std::min<Eigen::Index>(kRows, n - i0);
      for (Eigen::Index k = 0; k < depth; ++k) {
        const double* src = wa + k * lda + i0;
        for (Eigen::Index r = 0; r < kRows; ++r) a[k * kRows + r] = r < rows ? src[r] : 0.0;
      }
    }
    // Column blocks of kCols; each walks down from its diagonal tile, so P is read and written
    // once per pass, column block by column block.
    for (Eigen::Index j0 = 0; j0 < n; j0 += kCols) {
      const int cols = static_cast<int>(std::min<Eigen::Index>(kCols, n - j0));
      for (Eigen::Index k = 0; k < depth; ++k) {
        for (int c = 0; c < kCols; ++c) {
          const double v = c < cols ? wb[k * ldb + j0 + c] : 0.0;
          b[k * kCols + c] = Vec{} + v;
        }
      }
      // From the tile holding row j0 (its rows above the diagonal are computed, not stored).
      for (Eigen::Index t = j0 / kRows; t < blocks; ++t)
        tile(p, ld, packed.data() + t * kRows * depth, depth, b, t * kRows, j0, n, cols);
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
