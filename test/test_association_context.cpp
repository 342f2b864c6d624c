// AssociationContext against dense reference computations with the full Jacobian H (2 x (3+2n))
// and a full, correlated covariance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include "association_fixtures.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {
namespace test_association_context {

using assoc_test::Scene;

// Dense H of observation model for landmark j.
Eigen::MatrixXd fullJacobian(const Scene& s, int j) {
  const int n = static_cast<int>(s.landmarks.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, 3 + 2 * n);
  Matrix23d Hp;
  Eigen::Matrix2d Hl;
  s.model.predict(s.ekf.pose(), s.ekf.landmark(j), &Hp, &Hl);
  H.leftCols<3>() = Hp;
  H.block<2, 2>(0, 3 + 2 * j) = Hl;
  return H;
}

// A scene with a correlated full covariance and a sensor offset.
void correlatedScene(Scene* s, std::mt19937* rng) {
  s->model.setSensorOffset(Eigen::Vector3d(0.5, 0.2, 0.1));
  s->est_pose = Eigen::Vector3d(2.0, -1.0, 0.4);
  s->true_pose = Eigen::Vector3d(2.3, -0.8, 0.43);
  std::uniform_real_distribution<double> u(-15.0, 15.0);
  for (int j = 0; j < 6; ++j) s->addLandmark(Eigen::Vector2d(2.0 + u(*rng), -1.0 + u(*rng)));
  const int dim = 3 + 2 * 6;
  Eigen::MatrixXd A = Eigen::MatrixXd::Random(dim, dim);
  s->full_covariance = 0.05 * A * A.transpose() + 0.01 * Eigen::MatrixXd::Identity(dim, dim);
  s->build();
  for (int j = 0; j < 6; ++j) s->observeLandmark(j, rng);
}

TEST(AssociationContext, IndividualMatchesDenseReference) {
  std::mt19937 rng(1);
  Scene s;
  correlatedScene(&s, &rng);
  const AssociationContext ctx = s.context();
  const Eigen::MatrixXd& P = s.ekf.covariance();
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      const Eigen::MatrixXd H = fullJacobian(s, j);
      const Eigen::Matrix2d S = H * P * H.transpose() + s.observations[i].R;
      const Eigen::Vector2d z_hat = s.model.predict(s.ekf.pose(), s.ekf.landmark(j));
      const Eigen::Vector2d v(s.observations[i].z(0) - z_hat(0),
                              wrapAngle(s.observations[i].z(1) - z_hat(1)));
      const auto ind = ctx.individual(i, j);
      EXPECT_TRUE(ind.S.isApprox(S, 1e-12));
      EXPECT_TRUE(ind.v.isApprox(v, 1e-12));
      EXPECT_TRUE((ind.S * ind.S_inv).isApprox(Eigen::Matrix2d::Identity(), 1e-10));
      EXPECT_NEAR(ind.mahalanobis, v.dot(S.inverse() * v), 1e-9 * (1 + ind.mahalanobis));
      EXPECT_NEAR(ind.log_det_S, std::log(S.determinant()), 1e-10);
      EXPECT_TRUE(ctx.prediction(j).z_hat.isApprox(z_hat, 1e-14));
    }
  }
  EXPECT_EQ(ctx.evaluations(), 36u);
}

TEST(AssociationContext, JointCovarianceMatchesDenseReference) {
  std::mt19937 rng(2);
  Scene s;
  correlatedScene(&s, &rng);
  const AssociationContext ctx = s.context();
  const Eigen::MatrixXd& P = s.ekf.covariance();
  // A hypothesis incl. one observation used twice (R appears only on its own blocks).
  const std::vector<std::pair<int, int>> pairs = {{0, 0}, {2, 3}, {1, 4}, {2, 5}};
  const int k = static_cast<int>(pairs.size());
  Eigen::MatrixXd H(2 * k, P.cols());
  Eigen::MatrixXd Rj = Eigen::MatrixXd::Zero(2 * k, 2 * k);
  Eigen::VectorXd v_ref(2 * k);
  for (int a = 0; a < k; ++a) {
    H.middleRows<2>(2 * a) = fullJacobian(s, pairs[a].second);
    const Eigen::Vector2d z_hat = s.model.predict(s.ekf.pose(), s.ekf.landmark(pairs[a].second));
    v_ref.segment<2>(2 * a) =
        RangeBearingModel::innovation(s.observations[pairs[a].first].z, z_hat);
    for (int b = 0; b < k; ++b) {
      if (pairs[a].first == pairs[b].first) {
        Rj.block<2, 2>(2 * a, 2 * b) = s.observations[pairs[a].first].R;
      }
    }
  }
  const Eigen::MatrixXd S_ref = H * P * H.transpose() + Rj;
  Eigen::VectorXd v;
  Eigen::MatrixXd S;
  ctx.jointInnovation(pairs, &v, &S);
  EXPECT_TRUE(v.isApprox(v_ref, 1e-12));
  EXPECT_TRUE(S.isApprox(S_ref, 1e-12));
  EXPECT_TRUE(ctx.innovationCovariance(2, 3, 1, 4).isApprox(S_ref.block<2, 2>(2, 4), 1e-12));
  EXPECT_TRUE(ctx.innovationCovariance(2, 3, 2, 5).isApprox(S_ref.block<2, 2>(2, 6), 1e-12));
  // The blocks of the last pair with the ones before it, stacked (the joint search's extension).
  Eigen::MatrixXd stacked(2 * (k - 1), 2);
  ctx.innovationCovariances(pairs, k - 1, pairs[k - 1].first, pairs[k - 1].second, stacked);
  EXPECT_TRUE(stacked.isApprox(S_ref.block(0, 2 * (k - 1), 2 * (k - 1), 2), 1e-12));
  const double d2_ref = v_ref.dot(S_ref.ldlt().solve(v_ref));
  EXPECT_NEAR(ctx.jointMahalanobis(pairs), d2_ref, 1e-8 * d2_ref);
  EXPECT_DOUBLE_EQ(ctx.jointMahalanobis({}), 0.0);
  // One pair: D^2 = M_ij.
  EXPECT_NEAR(ctx.jointMahalanobis({{3, 3}}), ctx.individual(3, 3).mahalanobis, 1e-9);
}

TEST(AssociationContext, CandidatesComeFromTheSpatialIndex) {
  Scene s;
  s.est_pose = s.true_pose = Eigen::Vector3d(0, 0, 0);
  s.addLandmark(Eigen::Vector2d(10, 0));     // 0: observed, 10 m
  s.addLandmark(Eigen::Vector2d(0, -14));    // 1: within 12 m + 5 m
  s.addLandmark(Eigen::Vector2d(-16, 5));    // 2: within 17 m, behind
  s.addLandmark(Eigen::Vector2d(30, 0));     // 3: out
  s.addLandmark(Eigen::Vector2d(500, 500));  // 4: far away
  s.build();
  {
    const AssociationContext ctx = s.context();
    EXPECT_TRUE(ctx.candidateLandmarks(5.0).empty());  // empty scan
  }
  s.observeLandmark(0);
  s.observePoint(Eigen::Vector2d(0, 12));
  const AssociationContext ctx = s.context();
  EXPECT_EQ(ctx.candidateLandmarks(5.0), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(ctx.candidateLandmarks(0.5), (std::vector<int>{0}));
  EXPECT_EQ(ctx.landmarksNear(Eigen::Vector2d(490, 490), 20.0), (std::vector<int>{4}));
  EXPECT_EQ(ctx.landmarkId(4), Scene::idOf(4));
  EXPECT_TRUE(ctx.observedPosition(1).isApprox(Eigen::Vector2d(0, 12), 1e-12));
  EXPECT_EQ(ctx.evaluations(), 0u);
}

TEST(AssociationContext, EvaluationsDoNotGrowWithTheMap) {
  // 4 landmarks around the robot, plus a growing number far away: NN's cost stays the same.
  std::size_t first = 0;
  for (int far : {0, 100, 600}) {
    Scene s;
    for (int j = 0; j < 4; ++j) s.addLandmark(Eigen::Vector2d(5.0 + 3 * j, 2.0 * (j % 2)));
    for (int j = 0; j < far; ++j) s.addLandmark(Eigen::Vector2d(1000.0 + j, -800.0 + 0.5 * j));
    s.build();
    for (int j = 0; j < 4; ++j) s.observeLandmark(j);
    const AssociationContext ctx = s.context();
    NN nn;
    nn.configure(MapParameterSource());
    const AssociationResult r = nn.associate(ctx);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
    if (far == 0) first = ctx.evaluations();
    EXPECT_EQ(ctx.evaluations(), first) << far;
  }
  EXPECT_EQ(first, 16u);
}

TEST(AssociationContext, BearingWrapsBehindTheRobot) {
  Scene s;
  s.est_pose = Eigen::Vector3d(0, 0, 0);
  s.true_pose = Eigen::Vector3d(0, 0, -0.02);  // turned a little: the bearing crosses +-pi
  s.addLandmark(Eigen::Vector2d(-10, 0.1));
  s.build();
  s.observeLandmark(0);
  const AssociationContext ctx = s.context();
  EXPECT_LT(s.observations[0].z(1), -M_PI + 0.1);     // observed just past -pi
  EXPECT_GT(ctx.prediction(0).z_hat(1), M_PI - 0.1);  // predicted just below +pi
  const auto ind = ctx.individual(0, 0);
  EXPECT_NEAR(ind.v(1), 0.02, 1e-9);
  EXPECT_LT(ind.mahalanobis, 5.99);
}

TEST(AssociationContext, DecisionNames) {
  EXPECT_STREQ(toString(Decision::kPaired), "paired");
  EXPECT_STREQ(toString(Decision::kNew), "new");
  EXPECT_STREQ(toString(Decision::kTentative), "tentative");
  EXPECT_STREQ(toString(Decision::kRejected), "rejected");
}

}  // namespace test_association_context
}  // namespace ekf_slam
