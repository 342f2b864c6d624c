// The rank-d downdate's register-tiled kernel (lowerProductDowndate), written once and compiled
// twice: by symmetric_rank_update.cpp at the build's own vector width, and, on x86-64, by
// symmetric_rank_update_avx2.cpp with -mavx2 for the CPUs that have it (chosen at run time).
// Every element of P subtracts the sum of its d products, added in the same order in every
// variant, and without -mfma none contracts them into FMA: the variants agree to the bit.
//
// Private to those two files. The includer defines EKF_SLAM_KERNEL_LANES (doubles per vector, 2
// or 4) and EKF_SLAM_KERNEL_NAMESPACE (a namespace of its own: the vector types differ). Nothing
// here calls an inline function from another header (no std::, no Eigen): such a function, compiled
// with -mavx2 in one file, could be the copy the linker keeps for every caller, and crash on a CPU
// without AVX2.
#include <cstddef>

namespace ekf_slam {
namespace EKF_SLAM_KERNEL_NAMESPACE {
namespace {

using Index = std::ptrdiff_t;
inline Index smaller(Index a, Index b) { return a < b ? a : b; }
inline Index larger(Index a, Index b) { return a < b ? b : a; }

// Doubles per vector: 2 (SSE2) or 4 (AVX). GCC/Clang vector extensions, so that the compiler
// picks the instructions (and contracts a * b + c into FMA only where the target has it, i.e.
// under -DEKF_SLAM_NATIVE=ON).
constexpr int kLanes = EKF_SLAM_KERNEL_LANES;
typedef double Vec __attribute__((vector_size(kLanes * sizeof(double))));
// Same, for loads and stores at any double-aligned address (P, A and B have leading dimensions of
// any size).
typedef double VecU __attribute__((vector_size(kLanes * sizeof(double)), aligned(sizeof(double))));

// Register tile: kRows x kCols of P, 12 SSE2 or 8 AVX accumulators (with the operands, within the
// 16 vector registers). The shapes are the fastest measured here (bench_rank_update): 6 x 4 with
// SSE2, 4 x 8 with AVX2 + FMA (kept for AVX2 without FMA).
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
inline void tile(double* P, Index ld, const double* a, Index d, const Vec* b, Index i0, Index j0,
                 Index n, int cols) {
  Vec acc[kRowVecs][kCols] = {};
  for (Index k = 0; k < d; ++k, a += kRows) {
    const Vec* bk = b + k * kCols;
#pragma GCC unroll 4
    for (int r = 0; r < kRowVecs; ++r) {
      const Vec ar = load(a + r * kLanes);
#pragma GCC unroll 8
      for (int c = 0; c < kCols; ++c) acc[r][c] += ar * bk[c];
    }
  }
  const Index rows = smaller(kRows, n - i0);
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
    for (Index i = larger(i0, j0 + c); i < i0 + rows; ++i) {
      const Index r = i - i0;
      p[i] -= acc[r / kLanes][c][r % kLanes];
    }
  }
}

}  // namespace

// Doubles of workspace productDowndate needs for n x d operands.
std::ptrdiff_t packedSize(std::ptrdiff_t n, std::ptrdiff_t d) {
  return (n + kRows - 1) / kRows * kRows * smaller(kDepth, d);
}

// P -= A B^T on the lower triangle (P n x n with leading dimension ld; A, B n x d), with
// packedSize(n, d) doubles of workspace.
void productDowndate(double* p, std::ptrdiff_t ld, std::ptrdiff_t n, const double* A_data,
                     std::ptrdiff_t lda, const double* B_data, std::ptrdiff_t ldb, std::ptrdiff_t d,
                     double* packed) {
  const Index blocks = (n + kRows - 1) / kRows;
  Vec b[kDepth * kCols];
  for (Index k0 = 0; k0 < d; k0 += kDepth) {
    const Index depth = smaller(kDepth, d - k0);
    const double* wa = A_data + k0 * lda;
    const double* wb = B_data + k0 * ldb;
    // A's rows in tiles, k-major within a tile: the kernel then reads one stream (O(n d), against
    // the downdate's n^2 d / 2 multiply-adds).
    for (Index t = 0; t < blocks; ++t) {
      double* a = packed + t * kRows * depth;
      const Index i0 = t * kRows, rows = smaller(kRows, n - i0);
      for (Index k = 0; k < depth; ++k) {
        const double* src = wa + k * lda + i0;
        for (Index r = 0; r < kRows; ++r) a[k * kRows + r] = r < rows ? src[r] : 0.0;
      }
    }
    // Column blocks of kCols; each walks down from its diagonal tile, so P is read and written
    // once per pass, column block by column block.
    for (Index j0 = 0; j0 < n; j0 += kCols) {
      const int cols = static_cast<int>(smaller(kCols, n - j0));
      for (Index k = 0; k < depth; ++k) {
        for (int c = 0; c < kCols; ++c) {
          const double v = c < cols ? wb[k * ldb + j0 + c] : 0.0;
          b[k * kCols + c] = Vec{} + v;
        }
      }
      // From the tile holding row j0 (its rows above the diagonal are computed, not stored).
      for (Index t = j0 / kRows; t < blocks; ++t)
        tile(p, ld, packed + t * kRows * depth, depth, b, t * kRows, j0, n, cols);
    }
  }
}

}  // namespace EKF_SLAM_KERNEL_NAMESPACE
}  // namespace ekf_slam
