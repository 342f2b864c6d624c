// EkfSlam's covariance storage: spare capacity (adding landmarks copies P O(log n) times), removal
// in place, no heap allocation in update() once its workspaces have grown, the lower-triangle rank
// downdate against a plain product, and the parts of P that stay current after an update.
#include <dlfcn.h>

#include <atomic>
#include <cstdlib>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/symmetric_rank_update.h"

// Counts malloc calls while counting is on (glibc: the program's malloc wins over libc's, and
// operator new and Eigen's aligned_malloc both go through it). Not under AddressSanitizer, which
// owns malloc and free (scripts/sanitize.sh): the counting test is skipped there.
namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_mallocs{0};
}  // namespace
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kCanCountMallocs = false;
#else
constexpr bool kCanCountMallocs = true;
extern "C" void* __libc_malloc(std::size_t size);
extern "C" void* malloc(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_mallocs.fetch_add(1);
  return __libc_malloc(size);
}
#endif

namespace ekf_slam {
namespace test_ekf_storage {

// A filter with n landmarks on a ring around the pose, each observed once.
EkfSlam ringFilter(int n, const RangeBearingModel& model) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, 0.1, 0.01).asDiagonal());
  const Eigen::Matrix2d R = Eigen::Vector2d(0.25, 0.003).asDiagonal();
  for (int i = 0; i < n; ++i) {
    const double b = -3.0 + 6.0 * i / n;
    EXPECT_NE(ekf.addLandmark(Eigen::Vector2d(10.0 + i % 7, b), R, model), kNoLandmark);
  }
  return ekf;
}

// Pairings with the landmarks of the given indices, observed a little off their estimate.
std::vector<Pairing> pairings(const EkfSlam& ekf, const std::vector<int>& idx,
                              const RangeBearingModel& model) {
  std::vector<Pairing> p;
  for (int i : idx) {
    const Eigen::Vector2d z = model.predict(ekf.pose(), ekf.landmark(i), nullptr, nullptr);
    p.push_back({ekf.landmarkIds()[i], z + Eigen::Vector2d(0.05, -0.002),
                 Eigen::Vector2d(0.25, 0.003).asDiagonal()});
  }
  return p;
}

TEST(EkfStorage, AddingLandmarksGrowsTheStorageGeometrically) {
  EkfSlam ekf;
  std::set<Eigen::Index> capacities;
  const RangeBearingModel model;
  for (int i = 0; i < 600; ++i) {
    ekf.addLandmark(Eigen::Vector2d(5.0 + i % 11, 0.01 * i), Eigen::Matrix2d::Identity(), model);
    capacities.insert(ekf.covarianceCapacity());
    ASSERT_GE(ekf.covarianceCapacity(), ekf.covariance().rows());
  }
  // 3 -> 1203 rows growing by half: about log(400) / log(1.5) = 15 copies, not 600.
  EXPECT_LE(capacities.size(), 20u);
  EXPECT_EQ(ekf.covariance().rows(), 3 + 2 * 600);
  EXPECT_EQ((ekf.covariance() - ekf.covariance().transpose()).cwiseAbs().maxCoeff(), 0.0);
}

TEST(EkfStorage, RemovalKeepsTheStorageAndTheOtherEntries) {
  const RangeBearingModel model;
  EkfSlam ekf = ringFilter(40, model);
  ASSERT_TRUE(ekf.update(pairings(ekf, {0, 5, 17, 39}, model), model));
  const Eigen::MatrixXd P0 = ekf.covariance();
  const Eigen::Index cap = ekf.covarianceCapacity();
  const LandmarkId gone = ekf.landmarkIds()[12];
  ASSERT_TRUE(ekf.removeLandmark(gone));
  EXPECT_EQ(ekf.covarianceCapacity(), cap);
  const Eigen::Index r = ekf.stateRow(12), n = P0.rows() - 2;
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < P0.rows(); ++i) {
    if (i != r && i != r + 1) keep.push_back(i);
  }
  ASSERT_EQ(ekf.covariance().rows(), n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      ASSERT_EQ(ekf.covariance()(i, j), P0(keep[i], keep[j])) << i << ", " << j;
    }
  }
}

TEST(EkfStorage, UpdateShapesAreCountedOnlyWhenAsked) {
  const RangeBearingModel model;
  EkfSlam ekf = ringFilter(20, model);  // N = 43
  ASSERT_TRUE(ekf.update(pairings(ekf, {1, 5, 9}, model), model));
  EXPECT_TRUE(ekf.updateStats().shapes.empty());
  ekf.recordUpdateShapes(true);
  ASSERT_TRUE(ekf.update(pairings(ekf, {1, 5, 9}, model), model));
  ASSERT_TRUE(ekf.update(pairings(ekf, {2, 6, 10}, model), model));
  ASSERT_TRUE(ekf.update(pairings(ekf, {3}, model), model));
  const auto& shapes = ekf.updateStats().shapes;
  ASSERT_EQ(shapes.size(), 2u);
  EXPECT_EQ(shapes.at({43, 6}), 2u);  // N = 3 + 2 x 20, d = 2 x 3 pairings
  EXPECT_EQ(shapes.at({43, 2}), 1u);
}

TEST(EkfStorage, UpdateDoesNotAllocateOnceWarm) {
  if (!kCanCountMallocs) GTEST_SKIP() << "AddressSanitizer owns malloc: allocations not counted";
  const RangeBearingModel model;
  EkfSlam ekf = ringFilter(400, model);  // N = 803: the downdate splits its products
  const std::vector<int> big = {1, 40, 77, 130, 201, 260, 301, 333, 350, 399};
  ASSERT_TRUE(ekf.update(pairings(ekf, big, model), model));  // grows the workspaces
  const std::vector<Pairing> a = pairings(ekf, big, model), b = pairings(ekf, {3, 9, 300}, model);
  g_mallocs = 0;
  g_counting = true;
  const bool ok = ekf.update(a, model) && ekf.update(b, model);
  g_counting = false;
  EXPECT_TRUE(ok);
  EXPECT_EQ(g_mallocs.load(), 0);
  // The counter does count: a fresh matrix allocates.
  g_counting = true;
  const Eigen::MatrixXd copy = ekf.covariance();
  g_counting = false;
  EXPECT_GT(g_mallocs.load(), 0);
}

// Every kernel this build and CPU can run (the test runs each in turn).
std::vector<RankDowndateKernel> availableKernels() {
  std::vector<RankDowndateKernel> kernels;
  for (const RankDowndateKernel k : {RankDowndateKernel::kBaseline, RankDowndateKernel::kAvx2}) {
    if (rankDowndateKernelAvailable(k)) kernels.push_back(k);
  }
  return kernels;
}

// Puts the process's kernel back when the test ends.
struct KernelRestorer {
  RankDowndateKernel kernel = rankDowndateKernel();
  ~KernelRestorer() { selectRankDowndateKernel(kernel); }
};

TEST(EkfStorage, DowndateEqualsTheProductOnTheLowerTriangle) {
  const KernelRestorer restore;
  for (const RankDowndateKernel kernel : availableKernels()) {
    SCOPED_TRACE(toString(kernel));
    ASSERT_TRUE(selectRankDowndateKernel(kernel));
    std::mt19937 rng(3);
    std::normal_distribution<double> g;
    std::vector<double> workspace;  // reused across sizes, as EkfSlam does
    for (const Eigen::Index n : {1, 7, 128, 129, 300, 1500}) {
      // d = 130: more columns of W than one pass of the kernel takes.
      for (const Eigen::Index d : {1, 2, 12, 130}) {
        if (n * n * d > 300 * 300 * 130) continue;
        Eigen::MatrixXd W(n, d), A(n, n);
        for (Eigen::Index i = 0; i < W.size(); ++i) W(i) = 0.1 * g(rng);
        for (Eigen::Index i = 0; i < A.size(); ++i) A(i) = g(rng);
        // Stored with a leading dimension larger than n, as EkfSlam keeps it.
        Eigen::MatrixXd store = Eigen::MatrixXd::Constant(n + 5, n + 3, 42.0);
        store.topLeftCorner(n, n) = A + A.transpose();
        MatrixView P(store.data(), n, n, Eigen::OuterStride<>(n + 5));
        const Eigen::MatrixXd before = P;
        const Eigen::MatrixXd want = before - W * W.transpose();
        lowerRankDowndate(P, W, &workspace);
        const Eigen::MatrixXd lower = P.triangularView<Eigen::Lower>();
        const Eigen::MatrixXd want_lower = want.triangularView<Eigen::Lower>();
        EXPECT_LT((lower - want_lower).cwiseAbs().maxCoeff(), 1e-12) << n << " x " << d;
        const Eigen::MatrixXd upper = P.triangularView<Eigen::StrictlyUpper>();
        const Eigen::MatrixXd upper_before = before.triangularView<Eigen::StrictlyUpper>();
        EXPECT_EQ(upper, upper_before);
        // Nothing outside the n x n corner is touched.
        EXPECT_TRUE((store.bottomRows(5).array() == 42.0).all());
        EXPECT_TRUE((store.rightCols(3).array() == 42.0).all());
      }
    }
  }
}

// The AVX2 kernel's only business is speed: its result equals the baseline's to the bit (the
// same products added in the same order, no FMA), so that a run's output does not depend on the
// CPU it ran on.
TEST(EkfStorage, KernelsAgreeToTheBit) {
  if (!rankDowndateKernelAvailable(RankDowndateKernel::kAvx2)) {
    GTEST_SKIP() << "this build or CPU has no AVX2 kernel";
  }
  const KernelRestorer restore;
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  for (const Eigen::Index n : {5, 413, 700}) {
    for (const Eigen::Index d : {2, 14, 131}) {
      Eigen::MatrixXd W(n, d), B(n, d), A(n, n);
      for (Eigen::Index i = 0; i < W.size(); ++i) W(i) = 0.1 * g(rng);
      for (Eigen::Index i = 0; i < B.size(); ++i) B(i) = 0.1 * g(rng);
      for (Eigen::Index i = 0; i < A.size(); ++i) A(i) = g(rng);
      std::vector<Eigen::MatrixXd> results;
      for (const RankDowndateKernel kernel :
           {RankDowndateKernel::kBaseline, RankDowndateKernel::kAvx2}) {
        ASSERT_TRUE(selectRankDowndateKernel(kernel));
        Eigen::MatrixXd P = A + A.transpose();
        lowerRankDowndate(MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), W);
        lowerProductDowndate(MatrixView(P.data(), n, n, Eigen::OuterStride<>(n)), W, B);
        results.push_back(P);
      }
      EXPECT_TRUE((results[0].array() == results[1].array()).all()) << n << " x " << d;
    }
  }
}

TEST(EkfStorage, VehicleRowsAndLandmarkBlocksStayCurrentAfterAnUpdate) {
  const RangeBearingModel model;
  EkfSlam ekf = ringFilter(30, model);
  ASSERT_TRUE(ekf.update(pairings(ekf, {2, 11, 29}, model), model));
  const Eigen::MatrixXd stored = ekf.storedCovariance();
  const Eigen::MatrixXd full = ekf.covariance();  // completes the upper triangle
  EXPECT_EQ((full - full.transpose()).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(stored.topRows(3), full.topRows(3));
  EXPECT_EQ(Eigen::MatrixXd(stored.triangularView<Eigen::Lower>()),
            Eigen::MatrixXd(full.triangularView<Eigen::Lower>()));
  // Before completion the rest of the upper triangle was stale (the test can see a difference).
  EXPECT_GT((stored - full).cwiseAbs().maxCoeff(), 0.0);
  for (int i = 0; i < 30; ++i) {
    const int r = ekf.stateRow(i);
    EXPECT_EQ(Eigen::Matrix2d(stored.block<2, 2>(r, r)), ekf.landmarkCovariance(i));
    EXPECT_EQ(ekf.landmarkCovariance(i), Eigen::Matrix2d(full.block<2, 2>(r, r)));
    for (int j = 0; j < 30; ++j) {
      const int c = ekf.stateRow(j);
      EXPECT_EQ(ekf.blockCovariance(r, c), Eigen::Matrix2d(full.block<2, 2>(r, c)));
    }
  }
}

}  // namespace test_ekf_storage
}  // namespace ekf_slam
