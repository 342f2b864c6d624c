// Hand-made association problems for the associator tests (NN, JCBB, NNJCBB, Hungarian, DJNN).
//
//   assoc_test::Scene s;
//   s.est_pose = {0, 0, 0};  s.true_pose = {1.5, 0, 0.05};    // estimate vs truth
//   s.pose_cov = assoc_test::poseCov(1.0, 1.0, deg2rad(3));     // sigma x, y, yaw
//   s.addLandmark({10, 2});                                     // map landmark 0 (id 100)
//   s.build();                                                  // EKF + spatial index
//   s.observeLandmark(0);                                       // from the true pose
//   s.observePoint({5, -5});                                    // clutter / new feature
//   AssociationContext ctx = s.context();
//   ... assoc.associate(ctx) ... s.expectId(obs) is the right answer's id (kNoLandmark: none)
//
// Landmark ids are 100 + index so tests cannot confuse ids with state-order indices.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {
namespace assoc_test {

inline Eigen::Matrix3d poseCov(double sx, double sy, double syaw) {
  return Eigen::Vector3d(sx * sx, sy * sy, syaw * syaw).asDiagonal();
}
inline Eigen::Matrix2d diag2(double a, double b) {
  return Eigen::Vector2d(a * a, b * b).asDiagonal();
}

struct Scene {
  // --- what the filter believes ---------------------------------------------------------------
  Eigen::Vector3d est_pose = Eigen::Vector3d::Zero();
  Eigen::Matrix3d pose_cov = poseCov(0.1, 0.1, 0.01);
  std::vector<Eigen::Vector2d> landmarks;      ///< estimated positions, state order
  std::vector<Eigen::Matrix2d> landmark_covs;  ///< one per landmark
  /// When non-empty (size 3 + 2n), replaces the block-diagonal covariance built from pose_cov and
  /// landmark_covs (e.g. to add pose-map correlations).
  Eigen::MatrixXd full_covariance;

  // --- the world ------------------------------------------------------------------------------
  Eigen::Vector3d true_pose = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> true_landmarks;  ///< defaults to `landmarks`
  Eigen::Matrix2d R = diag2(0.1, 0.01);         ///< measurement noise (range m, bearing rad)

  RangeBearingModel model;
  EkfSlam ekf;
  LandmarkIndex index{10.0};
  std::vector<Observation> observations;
  std::vector<int> truth;  ///< per observation: state-order index of its source, -1 none

  /// Adds a map landmark (estimate `p`, covariance `cov`); its true position is `p` too unless
  /// set with `true_p`. Returns its state-order index.
  int addLandmark(const Eigen::Vector2d& p, const Eigen::Matrix2d& cov = diag2(0.05, 0.05)) {
    landmarks.push_back(p);
    landmark_covs.push_back(cov);
    true_landmarks.push_back(p);
    return static_cast<int>(landmarks.size()) - 1;
  }
  int addLandmark(const Eigen::Vector2d& p, const Eigen::Matrix2d& cov,
                  const Eigen::Vector2d& true_p) {
    const int j = addLandmark(p, cov);
    true_landmarks[j] = true_p;
    return j;
  }

  static LandmarkId idOf(int index) { return 100 + index; }

  /// Loads the map into the EKF (EkfSlam::setState) and the spatial index.
  void build() {
    const int n = static_cast<int>(landmarks.size());
    Eigen::VectorXd mean(3 + 2 * n);
    mean.head<3>() = est_pose;
    Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(3 + 2 * n, 3 + 2 * n);
    cov.topLeftCorner<3, 3>() = pose_cov;
    std::vector<LandmarkId> ids(n);
    for (int j = 0; j < n; ++j) {
      mean.segment<2>(3 + 2 * j) = landmarks[j];
      cov.block<2, 2>(3 + 2 * j, 3 + 2 * j) = landmark_covs[j];
      ids[j] = idOf(j);
    }
    if (full_covariance.size() > 0) cov = full_covariance;
    ekf.setState(mean, cov, ids);
    index.clear();
    index.sync(ekf);
  }

  /// Observation of a world point from the true pose, optionally with noise drawn from R.
  int observePoint(const Eigen::Vector2d& p, std::mt19937* rng = nullptr, int source = -1) {
    Observation o;
    o.z = model.predict(true_pose, p);
    o.R = R;
    if (rng) {
      std::normal_distribution<double> n01(0.0, 1.0);
      const Eigen::LLT<Eigen::Matrix2d> llt(R);
      const Eigen::Vector2d e(n01(*rng), n01(*rng));
      o.z += llt.matrixL() * e;
    }
    o.z(1) = wrapAngle(o.z(1));
    observations.push_back(o);
    truth.push_back(source);
    return static_cast<int>(observations.size()) - 1;
  }
  /// Observation of map landmark j (at its true position). Returns the observation index.
  int observeLandmark(int j, std::mt19937* rng = nullptr) {
    return observePoint(true_landmarks[j], rng, j);
  }
  /// Observes every landmark within `range` of the true sensor position, in landmark order.
  void observeAll(double range, std::mt19937* rng = nullptr) {
    const Eigen::Vector3d s = model.sensorPose(true_pose);
    for (std::size_t j = 0; j < true_landmarks.size(); ++j) {
      if ((true_landmarks[j] - s.head<2>()).norm() <= range)
        observeLandmark(static_cast<int>(j), rng);
    }
  }

  /// The right answer for observation i: the id of its source landmark, kNoLandmark when none.
  LandmarkId expectId(int obs) const { return truth[obs] >= 0 ? idOf(truth[obs]) : kNoLandmark; }

  /// Context over the current state; valid while the scene lives and is not rebuilt.
  AssociationContext context(double stamp = 0.0) const {
    return AssociationContext(ekf, model, index, observations, stamp);
  }
};

// --- ready-made scenes (each builds the map and generates the observations) --------------------

/// Six well separated landmarks around a well localised robot, all observed (noisy when rng).
inline void unambiguousScene(Scene* s, std::mt19937* rng = nullptr) {
  s->est_pose = s->true_pose = Eigen::Vector3d(1.0, 2.0, 0.3);
  s->pose_cov = poseCov(0.2, 0.2, 0.02);
  for (const Eigen::Vector2d& p :
       {Eigen::Vector2d(10, 5), Eigen::Vector2d(15, -6), Eigen::Vector2d(20, 12),
        Eigen::Vector2d(-3, 14), Eigen::Vector2d(-12, -4), Eigen::Vector2d(6, -15)}) {
    s->addLandmark(p);
  }
  s->build();
  s->observeAll(30.0, rng);
}

/// One landmark observed, plus two clutter points: observation 1 far from every landmark (a new
/// landmark), observation 2 at 0.8 m from landmark 0 (outside the pairing gate but too close to
/// be new: rejected).
inline void clutterScene(Scene* s) {
  s->pose_cov = poseCov(0.1, 0.1, 0.01);
  s->addLandmark(Eigen::Vector2d(10, 0), diag2(0.1, 0.1));
  s->build();
  s->observeLandmark(0);
  s->observePoint(Eigen::Vector2d(3, 8));
  s->observePoint(Eigen::Vector2d(10, 0.8));
}

/// Three landmarks behind the robot; the bearing of landmark 0 is observed just past -pi and
/// predicted just below +pi (the robot turned by -0.02 rad more than the filter believes).
inline void behindScene(Scene* s) {
  s->est_pose = Eigen::Vector3d(0, 0, 0);
  s->true_pose = Eigen::Vector3d(0, 0, -0.02);
  s->pose_cov = poseCov(0.2, 0.2, 0.03);
  s->addLandmark(Eigen::Vector2d(-10, 0.1));
  s->addLandmark(Eigen::Vector2d(-10, -4));
  s->addLandmark(Eigen::Vector2d(-12, 4.5));
  s->build();
  for (int j = 0; j < 3; ++j) s->observeLandmark(j);
}

/// Large pose error (truth 1.5 m and 4 deg away from the estimate, pose sigma 1 m / 4 deg, map
/// sigma 5 cm). Five landmarks plus a decoy placed where landmark 0's observation lands under the
/// estimated pose: NN pairs observation 0 with the decoy (the closer one individually), only the
/// joint test sees that the decoy disagrees with the pose error the other four pairings imply.
/// Observation i comes from landmark i (i = 0..4). Returns the decoy's index.
inline int largePoseErrorScene(Scene* s) {
  s->est_pose = Eigen::Vector3d(0, 0, 0);
  s->true_pose = Eigen::Vector3d(1.2, -0.9, deg2rad(4.0));
  s->pose_cov = poseCov(1.0, 1.0, deg2rad(4.0));
  s->R = diag2(0.1, deg2rad(0.5));
  const Eigen::Matrix2d map_cov = diag2(0.05, 0.05);
  for (const Eigen::Vector2d& p :
       {Eigen::Vector2d(10, 5), Eigen::Vector2d(15, -6), Eigen::Vector2d(20, 2),
        Eigen::Vector2d(8, -3), Eigen::Vector2d(25, 8)}) {
    s->addLandmark(p, map_cov);
  }
  // Where observation 0 appears from the estimated pose.
  const Eigen::Vector2d z0 = s->model.predict(s->true_pose, s->true_landmarks[0]);
  const Eigen::Vector2d seen = s->model.inverse(s->est_pose, z0);
  const int decoy = s->addLandmark(seen + Eigen::Vector2d(0.1, 0.05), map_cov);
  s->build();
  for (int j = 0; j < 5; ++j) s->observeLandmark(j);
  return decoy;
}

/// The edge cases every gated associator gets right: clutterScene (paired, new, rejected), an
/// empty map (new), an empty scan (no decision), behindScene (bearing wrap). `run(scene)` returns
/// the associator's result for a built scene.
template <typename Run>
void expectEdgeCases(Run run) {
  {
    Scene s;
    clutterScene(&s);
    const AssociationResult r = run(s);
    EXPECT_EQ(r.landmark[0], Scene::idOf(0));
    EXPECT_EQ(r.decision[1], Decision::kNew);
    EXPECT_EQ(r.decision[2], Decision::kRejected);
  }
  {
    Scene s;
    s.build();
    s.observePoint(Eigen::Vector2d(5, 1));
    const AssociationResult r = run(s);
    ASSERT_EQ(r.decision.size(), 1u);
    EXPECT_EQ(r.decision[0], Decision::kNew);
  }
  {
    Scene s;
    unambiguousScene(&s);
    s.observations.clear();
    s.truth.clear();
    EXPECT_TRUE(run(s).decision.empty());
  }
  {
    Scene s;
    behindScene(&s);
    const AssociationResult r = run(s);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i)) << i;
  }
}

}  // namespace assoc_test
}  // namespace ekf_slam
