// Batch smoother (core/smoothing/batch_smoother.h): Jacobians, the solution against the truth of
// a simulated loop, the consistency of its landmark covariances, bad input; and the odometry
// SlamPipeline hands it (ScanReport::motion).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/smoothing/batch_smoother.h"

namespace ekf_slam {
namespace test_batch_smoother {

TEST(RelativePose, JacobiansMatchFiniteDifferences) {
  const Eigen::Vector3d a(1.0, -2.0, 0.7), b(3.5, 0.5, -2.9);
  Eigen::Matrix3d Ja, Jb;
  relativePose(a, b, &Ja, &Jb);
  constexpr double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(k);
    Eigen::Vector3d da = relativePose(a + e, b) - relativePose(a - e, b);
    Eigen::Vector3d db = relativePose(a, b + e) - relativePose(a, b - e);
    da.z() = wrapAngle(da.z());
    db.z() = wrapAngle(db.z());
    EXPECT_LT((da / (2 * h) - Ja.col(k)).norm(), 1e-6) << k;
    EXPECT_LT((db / (2 * h) - Jb.col(k)).norm(), 1e-6) << k;
  }
  // b in a's frame, composed back onto a, is b.
  EXPECT_LT((composePose(a, relativePose(a, b)) - composePose(b, Eigen::Vector3d::Zero())).norm(),
            1e-12);
}

// A loop around a square of landmarks: the truth, and what a run gives the smoother (noisy
// odometry, noisy observations with their true landmarks, the starting point dead-reckoned).
struct Loop {
  std::vector<Eigen::Vector3d> truth;
  std::vector<Eigen::Vector2d> landmarks;
  std::vector<SmoothingScan> scans;
  std::vector<SmoothingLandmark> start;  // first sighting from the dead-reckoned pose
  RangeBearingModel model{Eigen::Vector3d(0.5, 0.2, 0.1)};
};

Loop makeLoop(unsigned seed, MeasurementKind kind = MeasurementKind::kRangeBearing) {
  Loop w;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  // Rows of landmarks 5 m either side of a 30 m square path, every 5 m.
  for (int t = 0; t < 30; t += 5)
    for (const double off : {-5.0, 5.0}) {
      w.landmarks.emplace_back(t, off);
      w.landmarks.emplace_back(30.0 + off, t);
      w.landmarks.emplace_back(30.0 - t, 30.0 + off);
      w.landmarks.emplace_back(off, 30.0 - t);
    }
  // Drive it once anticlockwise, 0.5 m a step, turning on the spot at the corners.
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  const Eigen::Vector3d sigma(0.02, 0.01, 0.01);  // odometry std dev per step (vehicle frame)
  const Eigen::Matrix2d R_rb = Eigen::Vector2d(0.1 * 0.1, 0.02 * 0.02).asDiagonal();
  Eigen::Vector3d dead = x;
  for (int k = 0; k < 4 * 61; ++k) {
    const bool corner = k % 61 == 60;
    const Eigen::Vector3d u(corner ? 0.0 : 0.5, 0.0, corner ? M_PI / 2 : 0.0);
    if (k > 0) x = composePose(x, u);
    w.truth.push_back(x);
    SmoothingScan s;
    s.stamp = 0.2 * k;
    if (k == 0) {
      s.pose = x;
      s.pose_covariance = Eigen::Matrix3d::Zero();
    } else {
      Eigen::Vector3d m = u;
      for (int j = 0; j < 3; ++j) m(j) += sigma(j) * n01(rng);
      s.linked = true;
      s.motion = m;
      s.motion_covariance = sigma.cwiseProduct(sigma).asDiagonal();
      dead = composePose(dead, m);
      s.pose = dead;
    }
    for (std::size_t j = 0; j < w.landmarks.size(); ++j) {
      const Eigen::Vector2d zt = w.model.predict(x, w.landmarks[j], MeasurementKind::kRangeBearing);
      if (zt(0) > 12.0 || std::abs(zt(1)) > 1.4) continue;
      SmoothingObservation o;
      o.landmark = static_cast<LandmarkId>(100 + j);
      o.kind = kind;
      if (kind == MeasurementKind::kRangeBearing) {
        o.R = R_rb;
        o.z = zt + Eigen::Vector2d(0.1 * n01(rng), 0.02 * n01(rng));
      } else {
        Eigen::Matrix2d J;
        RangeBearingModel::sensorPoint(zt, MeasurementKind::kRangeBearing, &J);
        o.R = J * R_rb * J.transpose();
        const Eigen::LLT<Eigen::Matrix2d> L(o.R);
        o.z = w.model.predict(x, w.landmarks[j], kind) +
              L.matrixL() * Eigen::Vector2d(n01(rng), n01(rng));
      }
      const bool seen = std::any_of(w.start.begin(), w.start.end(),
                                    [&](const SmoothingLandmark& l) { return l.id == o.landmark; });
      if (!seen) w.start.push_back({o.landmark, w.model.inverse(s.pose, o.z, kind)});
      s.observations.push_back(o);
    }
    w.scans.push_back(s);
  }
  return w;
}

double positionRmse(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]).head<2>().squaredNorm();
  return std::sqrt(sum / a.size());
}

Eigen::Vector2d trueLandmark(const Loop& w, LandmarkId id) { return w.landmarks[id - 100]; }

TEST(BatchSmoother, RecoversTheLoopFromDeadReckoning) {
  for (const MeasurementKind kind : {MeasurementKind::kRangeBearing, MeasurementKind::kCartesian}) {
    const Loop w = makeLoop(3, kind);
    const SmoothingResult r = smoothRun(w.scans, w.start, w.model);
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_TRUE(r.converged);
    std::vector<Eigen::Vector3d> dead;
    for (const SmoothingScan& s : w.scans) dead.push_back(s.pose);
    const double before = positionRmse(dead, w.truth), after = positionRmse(r.poses, w.truth);
    EXPECT_GT(before, 0.5);        // the dead reckoning has drifted ...
    EXPECT_LT(after, before / 3);  // ... the smoother closes the loop
    // The landmarks' errors fit their covariances (one run: correlated, so a loose bound).
    double nees = 0.0;
    for (std::size_t k = 0; k < r.landmarks.size(); ++k) {
      const Eigen::Vector2d e = r.landmarks[k].position - trueLandmark(w, r.landmarks[k].id);
      nees += e.dot(r.landmark_covariances[k].ldlt().solve(e)) / r.landmarks.size();
    }
    EXPECT_LT(nees, 6.0) << "kind " << static_cast<int>(kind);
    // The model is right: the cost at the solution is a chi2 draw with the reported dof.
    const double dof = static_cast<double>(r.degrees_of_freedom);
    EXPECT_GT(r.initial_cost, 4 * dof);  // the dead-reckoned start is far from it
    EXPECT_NEAR(r.final_cost / dof, 1.0, 5.0 * std::sqrt(2.0 / dof));
    EXPECT_EQ(r.dropped_observations, 0u);
  }
}

TEST(BatchSmoother, LandmarkCovariancesAreConsistentOverRuns) {
  // NEES of every landmark, averaged over runs: 2 for a consistent estimate.
  constexpr int kRuns = 25;
  double nees = 0.0;
  int count = 0;
  for (int run = 0; run < kRuns; ++run) {
    const Loop w = makeLoop(100 + run);
    const SmoothingResult r = smoothRun(w.scans, w.start, w.model);
    ASSERT_TRUE(r.ok) << r.error;
    ASSERT_EQ(r.landmark_covariances.size(), r.landmarks.size());
    for (std::size_t k = 0; k < r.landmarks.size(); ++k) {
      const Eigen::Vector2d e = r.landmarks[k].position - trueLandmark(w, r.landmarks[k].id);
      nees += e.dot(r.landmark_covariances[k].ldlt().solve(e));
      ++count;
    }
  }
  nees /= count;
  // Errors of one run's landmarks are correlated (through the poses), so the band is wider than
  // chi2(2 count) alone would give.
  EXPECT_GT(nees, 1.4);
  EXPECT_LT(nees, 2.8);
}

TEST(BatchSmoother, DropsObservationsOfLandmarksNotInTheMap) {
  Loop w = makeLoop(5);
  const LandmarkId removed = w.start.back().id;
  w.start.pop_back();
  std::size_t of_removed = 0;
  for (const SmoothingScan& s : w.scans)
    for (const SmoothingObservation& o : s.observations) of_removed += o.landmark == removed;
  ASSERT_GT(of_removed, 0u);
  const SmoothingResult r = smoothRun(w.scans, w.start, w.model);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.dropped_observations, of_removed);
  EXPECT_EQ(r.landmarks.size(), w.start.size());
}

TEST(BatchSmoother, CovariancesOfTheFirstLandmarksOnly) {
  const Loop w = makeLoop(8);
  const SmoothingResult all = smoothRun(w.scans, w.start, w.model);
  SmootherParams p;
  p.landmark_covariances = 5;
  const SmoothingResult some = smoothRun(w.scans, w.start, w.model, p);
  ASSERT_TRUE(all.ok && some.ok);
  ASSERT_EQ(some.landmark_covariances.size(), w.start.size());
  for (std::size_t k = 0; k < w.start.size(); ++k) {
    if (k < 5) {
      EXPECT_LT((some.landmark_covariances[k] - all.landmark_covariances[k]).norm(), 1e-12);
      EXPECT_GT(some.landmark_covariances[k].determinant(), 0.0);
    } else {
      EXPECT_FALSE(some.landmark_covariances[k].allFinite()) << k;
    }
    EXPECT_EQ(some.landmarks[k].position, all.landmarks[k].position);
  }
}

TEST(BatchSmoother, BadInputIsAnErrorNotANaN) {
  Loop w = makeLoop(6);
  w.scans[10].motion_covariance(1, 1) = std::numeric_limits<double>::quiet_NaN();
  SmoothingResult r = smoothRun(w.scans, w.start, w.model);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("scan 10"), std::string::npos) << r.error;
  // The poses returned are the filter's, untouched.
  ASSERT_EQ(r.poses.size(), w.scans.size());
  EXPECT_TRUE(r.poses[10].allFinite());

  w = makeLoop(6);
  w.scans[20].observations.at(0).R = -Eigen::Matrix2d::Identity();
  r = smoothRun(w.scans, w.start, w.model);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("scan 20"), std::string::npos) << r.error;

  // No scans at all: nothing to do.
  r = smoothRun({}, {}, w.model);
  EXPECT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.poses.empty());
}

TEST(BatchSmoother, UnlinkedScansAreAnchoredAtTheFilterPose) {
  // Two scans without odometry between them and nothing observed: each stays where the filter
  // put it (its own prior), instead of a singular system.
  std::vector<SmoothingScan> scans(2);
  scans[0].pose = Eigen::Vector3d(1, 2, 0.3);
  scans[1].pose = Eigen::Vector3d(5, -1, 2.0);
  const SmoothingResult r = smoothRun(scans, {}, RangeBearingModel());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_LT((r.poses[0] - scans[0].pose).norm(), 1e-9);
  EXPECT_LT((r.poses[1] - scans[1].pose).norm(), 1e-9);
}

// --- what SlamPipeline hands the smoother
// ---------------------------------------------------------

TEST(ScanReportMotion, IsTheOdometryBetweenScansInThePreviousFrame) {
  PipelineConfig config;
  config.initial_pose = Eigen::Vector3d(2.0, -1.0, 0.7);  // a heading, so that frames matter
  SlamPipeline pipeline(config, std::make_shared<NN>());
  OdometryInput odom;
  odom.twist = Eigen::Vector2d(1.0, 0.3);
  std::vector<ScanReport> reports;
  Eigen::Vector3d previous = pipeline.pose();
  for (int k = 0; k <= 40; ++k) {
    odom.stamp = 0.025 * k;
    pipeline.addOdometry(odom);
    if (k % 8 != 0) continue;
    // No observations: no update, so the filter's pose is the prediction alone.
    const ScanReport r = pipeline.processObservations(odom.stamp, {});
    const Eigen::Vector3d pose = pipeline.pose();
    if (reports.empty()) {
      EXPECT_FALSE(r.has_motion);
    } else {
      ASSERT_TRUE(r.has_motion);
      EXPECT_LT((r.motion - relativePose(previous, pose)).norm(), 1e-12);
      EXPECT_GT(r.motion.x(), 0.15);
    }
    if (reports.size() == 1) {
      // The first scan came at the start with no pose uncertainty, so the filter's covariance
      // at the second is the process noise between them: the report's, turned into the frame
      // of the first scan's pose.
      Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
      T.topLeftCorner<2, 2>() = rotation2d(previous.z());
      const Eigen::Matrix3d expected = T.transpose() * pipeline.poseCovariance() * T;
      EXPECT_LT((r.motion_covariance - expected).norm(), 1e-12 * (1.0 + expected.norm()));
      EXPECT_GT(r.motion_covariance.trace(), 0.0);
    }
    reports.push_back(r);
    previous = pose;
  }
  pipeline.reset();
  odom.stamp = 2.0;
  pipeline.addOdometry(odom);
  EXPECT_FALSE(pipeline.processObservations(2.0, {}).has_motion);  // a reset breaks the chain
}

}  // namespace test_batch_smoother
}  // namespace ekf_slam
