// DJNN in the sensor worlds of issue 13 (docs/djnn.md, "Movers among landmarks a camera misses"):
// admission with P_D < 1 (the P_D-aware score admits a feature after fewer sightings than the
// paper's counter, but the static test still needs admit_evidence sightings of one static point),
// and established landmarks that the bias test no longer removes when a mover passes by.
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/angles.h"
#include "ekf_slam/core/association/djnn.h"

namespace ekf_slam {
namespace {

using assoc_test::makeDjnn;
using assoc_test::Scene;

// The scan (0-based) at which a point seen in every scan becomes kNew; -1 if never in 10 scans.
int admittedAt(const std::map<std::string, std::string>& params) {
  Scene s;
  const int b = s.addLandmark({12, 6});
  s.build();
  DJNN d = makeDjnn(params);
  for (int k = 0; k < 10; ++k) {
    s.observations.clear();
    s.truth.clear();
    s.observeLandmark(b);
    s.observePoint({8, -3});
    if (d.associate(s.context(k)).decision.back() == Decision::kNew) return k;
  }
  return -1;
}

TEST(DJNNAdmission, StaticTestNeedsAdmitEvidenceSightingsAtLowDetectionProbability) {
  // P_D 0.3: a hit scores 2 (1 - 0.15) = 1.7, so T = 5.1 >= 4 at the third sighting.
  EXPECT_EQ(admittedAt({{"detection_probability", "0.3"}, {"admit_evidence", "4"}}), 2);
  // With the static test the fourth sighting admits it, as at P_D = 1.
  EXPECT_EQ(
      admittedAt(
          {{"detection_probability", "0.3"}, {"admit_evidence", "4"}, {"static_test", "true"}}),
      3);
  EXPECT_EQ(admittedAt({{"admit_evidence", "4"}, {"static_test", "true"}}), 3);
  EXPECT_EQ(admittedAt({{"admit_evidence", "4"}}), 3);
}

// A landmark paired 12 times with zero-mean errors, then with returns walking away from it (a mover
// passing close by): by default the bias test removes it; with bias_keep_pairings 10 only the
// biased pairing is withdrawn and the landmark stays.
TEST(DJNNAdmission, EstablishedLandmarkKeepsItsPlaceWhenAMoverPassesBy) {
  auto run = [](const std::string& keep, int* withdrawn) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(1e-3, 1e-3, 1e-5);
    s.R = assoc_test::diag2(0.05, deg2rad(0.5));
    const int a = s.addLandmark({10, 0}, assoc_test::diag2(0.01, 0.01));
    s.build();
    DJNN d = makeDjnn({{"bias_test", "true"},
                       {"individual_probability", "0.999"},
                       {"ambiguity_probability", "0.999"},
                       {"bias_keep_pairings", keep}});
    bool removed = false;
    *withdrawn = 0;
    for (int k = 1; k <= 20 && !removed; ++k) {
      s.observations.clear();
      s.truth.clear();
      const double y = k <= 12 ? (k % 2 ? 0.05 : -0.05) : 0.05 * (k - 12);
      s.observePoint({10.0, y}, nullptr, a);
      const AssociationResult r = d.associate(s.context(0.2 * k));
      removed = !r.remove.empty();
      *withdrawn += r.decision[0] == Decision::kRejected;
    }
    return removed;
  };
  int withdrawn = 0;
  EXPECT_TRUE(run("0", &withdrawn));
  EXPECT_FALSE(run("10", &withdrawn));
  EXPECT_GE(withdrawn, 1);
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
