// Cartesian observations (x, y in the sensor frame with a full 2x2 covariance) through the
// association context, every associator and the EKF: the same scene observed as range-bearing
// and as Cartesian points gives the same decisions, and the EKF's update and initialisation
// agree with the range-bearing ones to first order.
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/jcbb.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/association/rrwsc.h"

namespace ekf_slam {
namespace test_cartesian_observations {

using assoc_test::Scene;

// The scan's range-bearing observations as Cartesian points: z = (r cos b, r sin b),
// R = J R J^T with J = d(x, y) / d(r, b) at the observed point.
void toCartesian(Scene* s) {
  for (Observation& o : s->observations) {
    Eigen::Matrix2d J;
    o.z = RangeBearingModel::sensorPoint(o.z, o.kind, &J);
    o.R = J * o.R * J.transpose();
    o.kind = MeasurementKind::kCartesian;
  }
}

std::vector<std::unique_ptr<DataAssociation>> allAssociators() {
  std::vector<std::unique_ptr<DataAssociation>> out;
  out.emplace_back(new NN);
  out.emplace_back(new JCBB);
  out.emplace_back(new DJNN);
  out.emplace_back(new NNJCBB);
  out.emplace_back(new Hungarian);
  out.emplace_back(new RRWSC);
  for (auto& a : out) a->configure(MapParameterSource());
  return out;
}

void expectSameDecisions(void (*make)(Scene*), const char* what) {
  Scene rb, xy;
  make(&rb);
  make(&xy);
  toCartesian(&xy);
  auto a = allAssociators();
  auto b = allAssociators();
  for (std::size_t k = 0; k < a.size(); ++k) {
    const AssociationResult ra = a[k]->associate(rb.context());
    const AssociationResult rx = b[k]->associate(xy.context());
    EXPECT_EQ(ra.decision, rx.decision) << what << " " << a[k]->name();
    EXPECT_EQ(ra.landmark, rx.landmark) << what << " " << a[k]->name();
    for (std::size_t i = 0; i < rb.observations.size(); ++i) {
      if (rb.truth[i] >= 0 && a[k]->name() != "DJNN") {
        EXPECT_EQ(rx.landmark[i], rb.expectId(static_cast<int>(i))) << what << " " << a[k]->name();
      }
    }
  }
}

TEST(CartesianObservations, EveryAssociatorDecidesAsWithRangeBearing) {
  expectSameDecisions([](Scene* s) { assoc_test::unambiguousScene(s); }, "unambiguous");
  expectSameDecisions([](Scene* s) { assoc_test::clutterScene(s); }, "clutter");
  expectSameDecisions([](Scene* s) { assoc_test::behindScene(s); }, "behind");
}

// The individual compatibility of a Cartesian observation is the range-bearing one carried
// through J: v_xy ~ J v_rb, S_xy ~ J S_rb J^T (first order: J at the observed vs predicted point).
TEST(CartesianObservations, IndividualCompatibilityMatchesToFirstOrder) {
  Scene rb, xy;
  std::mt19937 rng(3);
  assoc_test::unambiguousScene(&rb, &rng);
  std::mt19937 rng2(3);
  assoc_test::unambiguousScene(&xy, &rng2);
  toCartesian(&xy);
  const AssociationContext ca = rb.context(), cx = xy.context();
  for (int i = 0; i < static_cast<int>(rb.observations.size()); ++i) {
    const int j = rb.truth[i];
    const AssociationContext::Individual a = ca.individual(i, j), x = cx.individual(i, j);
    EXPECT_NEAR(a.mahalanobis, x.mahalanobis, 0.05 * (1.0 + a.mahalanobis)) << i;
    EXPECT_LT(x.mahalanobis, chi2Quantile(0.999, 2));
    EXPECT_LT((ca.observedPosition(i) - cx.observedPosition(i)).norm(), 1e-9);  // same point
  }
}

// The EKF with a Cartesian pairing: the same posterior as with the range-bearing one, to first
// order; initialisation from a Cartesian point lands on the point with the propagated covariance.
TEST(CartesianObservations, EkfUpdateAndInitialisation) {
  const RangeBearingModel model(Eigen::Vector3d(0.5, 0.1, 0.2));
  auto fresh = [&]() {
    EkfSlam ekf;
    ekf.reset(Eigen::Vector3d(1, 2, 0.3), assoc_test::poseCov(0.3, 0.3, 0.05));
    return ekf;
  };
  const Eigen::Vector2d truth(6, 5);
  const Eigen::Vector2d z_rb = model.predict(Eigen::Vector3d(1.1, 1.9, 0.31), truth);
  const Eigen::Matrix2d R_rb = assoc_test::diag2(0.1, 0.02);
  Eigen::Matrix2d J;
  const Eigen::Vector2d z_xy =
      RangeBearingModel::sensorPoint(z_rb, MeasurementKind::kRangeBearing, &J);
  const Eigen::Matrix2d R_xy = J * R_rb * J.transpose();

  EkfSlam a = fresh(), b = fresh();
  const LandmarkId ia = a.addLandmark(z_rb, R_rb, model);
  const LandmarkId ib = b.addLandmark(z_xy, R_xy, model, MeasurementKind::kCartesian);
  ASSERT_NE(ib, kNoLandmark);
  EXPECT_LT((a.mean() - b.mean()).norm(), 1e-9);
  EXPECT_LT((a.covariance() - b.covariance()).norm(), 1e-9);  // exact: same point, J at it

  // A second sighting from a slightly different place.
  const Eigen::Vector2d z2_rb =
      model.predict(Eigen::Vector3d(1.1, 1.9, 0.31), truth + Eigen::Vector2d(0.05, -0.03));
  const Eigen::Vector2d z2_xy =
      RangeBearingModel::sensorPoint(z2_rb, MeasurementKind::kRangeBearing, &J);
  ASSERT_TRUE(a.update({Pairing{ia, z2_rb, R_rb}}, model));
  ASSERT_TRUE(
      b.update({Pairing{ib, z2_xy, J * R_rb * J.transpose(), MeasurementKind::kCartesian}}, model));
  EXPECT_LT((a.mean() - b.mean()).norm(), 1e-3);
  EXPECT_LT((a.covariance() - b.covariance()).norm(), 1e-3 * a.covariance().norm());
  EXPECT_TRUE(b.mean().allFinite());
}

}  // namespace test_cartesian_observations
}  // namespace ekf_slam
