// DJNN's remembered sightings (docs/djnn.md, "Closing the loops"): a marker seen on a first pass
// but never admitted leaves a hole in the map. Back there with the pose uncertain along a periodic
// row, the scan shifted by two spacings pairs every observation while the truth leaves the hole's
// observation "not in the map", and the likelihood prefers the shift. The remembered feature (its
// offset from a landmark paired at the time) explains that observation instead.
#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {
namespace test_djnn_remembered {

using assoc_test::makeDjnn;
using assoc_test::Scene;

constexpr int kHole = 3;  // the row's marker that never entered the map

Eigen::Vector2d marker(int k) { return {2.0 + 0.8 * k, 0.5}; }

// A row of markers 0.8 m apart (k = 0..9) known to a millimetre; marker kHole is not in the map.
// Returns the state index of each marker's landmark (-1 for the hole).
std::vector<int> rowWithHole(Scene* s, double pose_sd_along) {
  s->pose_cov = assoc_test::poseCov(pose_sd_along, 0.02, 0.002);
  s->R = assoc_test::diag2(0.03 * 0.03, deg2rad(1) * deg2rad(1));
  std::vector<int> index;
  for (int k = 0; k < 10; ++k) {
    index.push_back(k == kHole ? -1 : s->addLandmark(marker(k), assoc_test::diag2(1e-6, 1e-6)));
  }
  s->build();
  return index;
}

DJNN makeJoint(bool remember) {
  std::map<std::string, std::string> p = {{"loop_closure_age", "30"},
                                          {"landmark_density", "0.3"},
                                          {"individual_probability", "0.999"},
                                          {"ambiguity_probability", "0.999"},
                                          {"admit_evidence", "3"},
                                          {"tentative_timeout", "10"},
                                          {"static_test", "true"}};
  if (remember) p["remembered_sightings"] = "2";
  return makeDjnn(p);
}

// First pass, pose known: marker 2 is paired, the hole's marker seen twice (tentative), then the
// tentative feature times out (missed once, its evidence still positive).
void firstPass(DJNN* d) {
  Scene s;
  const std::vector<int> index = rowWithHole(&s, 0.02);
  for (double t : {0.0, 1.0}) {
    s.observations.clear();
    s.truth.clear();
    s.observeLandmark(index[2]);
    s.observePoint(marker(kHole));
    d->associate(s.context(t));
  }
  s.observations.clear();
  s.truth.clear();
  s.observePoint({-40.0, 0.0});   // beyond the sensor's reach
  d->associate(s.context(20.0));  // 19 s later: the tentative feature has timed out
}

// Back at the row 100 s later, pose uncertain along it: markers 2..5 are seen.
struct Closure {
  AssociationResult result;
  int right = 0, wrong = 0;
};
Closure loopClosure(DJNN* d, double pose_sd_along) {
  Scene s;
  const std::vector<int> index = rowWithHole(&s, pose_sd_along);
  std::vector<int> truth;
  for (int k = 2; k <= 5; ++k) {
    s.observePoint(marker(k));
    truth.push_back(index[k]);
  }
  Closure c;
  c.result = d->associate(s.context(100.0));
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (c.result.decision[i] != Decision::kPaired) continue;
    ++(truth[i] >= 0 && c.result.landmark[i] == Scene::idOf(truth[i]) ? c.right : c.wrong);
  }
  return c;
}

// Without the memory the shift (four pairings) and the truth (three, and the hole "not in the map")
// are within the margin: the scan is held. With it the truth explains all four and is decided; the
// hole's observation is admitted on its remembered feature.
TEST(DJNNRemembered, HoleIsExplainedAndTheTruthDecided) {
  for (const bool remember : {false, true}) {
    DJNN d = makeJoint(remember);
    firstPass(&d);
    EXPECT_EQ(d.stats().remembered, remember ? 1u : 0u);
    const Closure c = loopClosure(&d, 0.8);
    EXPECT_EQ(c.wrong, 0);
    if (remember) {
      EXPECT_EQ(c.right, 3);
      EXPECT_EQ(c.result.decision[1], Decision::kNew);  // marker kHole
      EXPECT_EQ(d.stats().remembered_admitted, 1u);
    } else {
      EXPECT_EQ(c.right, 0);
      EXPECT_EQ(d.stats().joint_held, 4u);
    }
  }
}

// A marker seen when no landmark was paired near it (the first seconds of a run, before the first
// landmark) has no anchor at its sightings. At its timeout it is anchored to the nearest landmark
// with both estimates' uncertainty, and the closure is decided as with an anchor. Without that it
// was forgotten, and a closure back to the start shifted the scan onto the mapped markers.
TEST(DJNNRemembered, AFeatureSeenWithNoLandmarkPairedIsAnchoredAtItsTimeout) {
  DJNN d = makeJoint(true);
  {
    Scene s;
    rowWithHole(&s, 0.005);
    s.pose_cov = assoc_test::poseCov(0.005, 0.005, 0.0005);  // near the start: known to 5 mm
    s.build();
    for (double t : {0.0, 1.0}) {
      s.observations.clear();
      s.truth.clear();
      s.observePoint(marker(kHole));  // nothing else seen: no landmark paired
      d.associate(s.context(t));
    }
    s.observations.clear();
    s.truth.clear();
    s.observePoint({-40.0, 0.0});
    d.associate(s.context(20.0));
  }
  EXPECT_EQ(d.stats().remembered, 1u);
  EXPECT_EQ(d.stats().remembered_late_anchor, 1u);
  const Closure c = loopClosure(&d, 0.8);
  EXPECT_EQ(c.wrong, 0);
  EXPECT_EQ(c.right, 3);
  EXPECT_EQ(c.result.decision[1], Decision::kNew);  // marker kHole
}

// Held sightings (docs/djnn.md, "Sightings held at a closure"): the held scan's observations feed
// tentative features that are never admitted; when the next scan, its pose now known, decides the
// closure, each pairing names the held feature of its marker, whose sightings the pipeline then
// applies to the landmark (core/pipeline/delayed_sightings.h). Off, the pairings name none.
TEST(DJNNRemembered, HeldSightingsJoinTheirLandmarkOnceDecided) {
  for (const bool join : {false, true}) {
    std::map<std::string, std::string> p = {{"loop_closure_age", "30"},
                                            {"landmark_density", "0.3"},
                                            {"individual_probability", "0.999"},
                                            {"ambiguity_probability", "0.999"},
                                            {"admit_evidence", "3"},
                                            {"remembered_sightings", "2"},
                                            {"held_sightings", join ? "true" : "false"}};
    DJNN d = makeDjnn(p);
    std::vector<FeatureKey> held;
    for (const double sd : {0.8, 0.02}) {
      Scene s;
      const std::vector<int> index = rowWithHole(&s, sd);
      for (int k = 4; k <= 7; ++k) s.observePoint(marker(k));
      const AssociationResult r = d.associate(s.context(sd > 0.5 ? 100.0 : 100.2));
      if (sd > 0.5) {  // the near tie: held, each observation a tentative feature of its own
        for (std::size_t i = 0; i < r.decision.size(); ++i) {
          EXPECT_EQ(r.decision[i], Decision::kTentative);
          held.push_back(r.feature[i]);
        }
        EXPECT_EQ(d.stats().joint_held, 4u);
        continue;
      }
      for (std::size_t i = 0; i < r.decision.size(); ++i) {
        ASSERT_EQ(r.decision[i], Decision::kPaired);
        EXPECT_EQ(r.landmark[i], Scene::idOf(index[4 + i]));
        EXPECT_EQ(r.feature[i], join ? held[i] : kNoFeature);
        // Either way the held feature ends (off: missed, its sightings let go).
        EXPECT_NE(std::find(r.ended_features.begin(), r.ended_features.end(), held[i]),
                  r.ended_features.end());
      }
      EXPECT_EQ(d.stats().held_joined, join ? 4u : 0u);
      EXPECT_TRUE(d.tentativeFeatures().empty());
    }
  }
}

// A tracked pairing's rival that is no map landmark (docs/djnn.md, "Tracked pairings are not
// held"): back in a closure scan, the marker paired a moment ago could also be the remembered
// feature beside it, a pose shift away. That rival leaves the observation out of the map, as
// "not in the map" does: it decides no closure, so the tracked pairing is decided, not held.
TEST(DJNNRemembered, ATrackedPairingWhoseRivalIsARememberedFeatureIsDecided) {
  DJNN d = makeJoint(true);
  firstPass(&d);  // marker 2 paired at 1 s; the hole's marker remembered beside it
  ASSERT_EQ(d.stats().remembered, 1u);
  // The same landmark ids: marker 2 where it was, one old landmark known only to a metre (it
  // makes the scan a closure scan without pinning the pose), the others out of view.
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.5, 0.02, 0.002);
  s.R = assoc_test::diag2(0.03 * 0.03, deg2rad(1) * deg2rad(1));
  int old = -1;
  for (int k = 0; k < 10; ++k) {
    if (k == kHole) continue;
    if (k == 2) {
      s.addLandmark(marker(2), assoc_test::diag2(1e-6, 1e-6));
    } else if (k == 5) {
      old = s.addLandmark({5.2, 3.0}, assoc_test::diag2(1.0, 1.0));
    } else {
      s.addLandmark({marker(k).x(), 40.0}, assoc_test::diag2(1e-6, 1e-6));
    }
  }
  s.build();
  s.observeLandmark(2);  // marker 2; the remembered one 0.8 m beside it
  s.observeLandmark(old);
  const std::uint64_t joint_scans = d.stats().joint_scans;
  const AssociationResult r = d.associate(s.context(25.0));  // marker 2 paired 24 s ago
  EXPECT_EQ(d.stats().joint_scans, joint_scans + 1);         // `old` makes it a closure scan
  EXPECT_EQ(r.decision[0], Decision::kPaired);
  EXPECT_EQ(r.landmark[0], Scene::idOf(2));
  EXPECT_NE(r.decision[1], Decision::kPaired);  // the closure itself is not decided
  EXPECT_EQ(d.stats().remembered_admitted, 0u);
}

TEST(DJNNRemembered, OffByDefaultAndValidated) {
  EXPECT_EQ(DJNN().params().remembered.remembered_sightings, 0);
  EXPECT_THROW(makeDjnn({{"remembered_sightings", "-1"}}), ParameterError);
}

}  // namespace test_djnn_remembered
}  // namespace ekf_slam
