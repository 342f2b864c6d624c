// DJNN's admission with P_D < 1: the P_D-aware score admits a feature after fewer sightings than
// the paper's counter, but the static test (which tells a slow mover from a landmark) still needs
// admit_evidence sightings of one static point. docs/djnn.md, "Admission with P_D < 1".
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
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

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
