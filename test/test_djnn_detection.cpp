// DJNN with a sensor model: the detection-probability-aware evidence score reproduces the paper's
// counter exactly at P_D = 1 without clutter, keeps landmarks a low-P_D sensor sees only now and
// then, and the minimum range / polygon bound the sensor region. docs/djnn.md.
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {
namespace test_djnn_detection {

using assoc_test::makeDjnn;
using assoc_test::Scene;

void clearScan(Scene* s) {
  s->observations.clear();
  s->truth.clear();
}

// Random hits and misses of three landmarks in view: DJNN's evidence must equal the paper's
// integer counter T = initial + hits - misses, scan by scan, and the landmark leave exactly when
// T reaches 0; with P_D = 1 / no clutter spelled out, and with P_D unset and the profile off (the
// paper's configuration, config/djnn_paper.yaml: nothing is estimated).
TEST(DJNNDetection, PaperCounterIsReproducedAtDetectionProbabilityOne) {
  for (const bool explicit_model : {false, true}) {
    Scene s;
    const std::vector<Eigen::Vector2d> where = {{10, 0}, {12, 6}, {15, -4}};
    for (const auto& p : where) s.addLandmark(p);
    s.build();
    DJNN d = explicit_model
                 ? makeDjnn({{"detection_probability", "1"}, {"clutter_density", "0"}})
                 : makeDjnn({{"detection_probability", ""}, {"missed_detection_profile", "false"}});
    EXPECT_FALSE(d.detectionEstimate().on());
    std::mt19937 rng(7);
    const double rate[] = {0.8, 0.5, 0.35};
    std::vector<int> expected(where.size(), 2);  // initial_evidence
    std::vector<bool> gone(where.size(), false);
    int misses = 0, removals = 0;
    for (int scan = 0; scan < 60; ++scan) {
      clearScan(&s);
      std::vector<bool> hit(where.size());
      for (std::size_t j = 0; j < where.size(); ++j) {
        hit[j] = !gone[j] && std::bernoulli_distribution(rate[j])(rng);
        if (hit[j]) s.observeLandmark(static_cast<int>(j));
      }
      if (s.observations.empty()) continue;  // empty scans change nothing (tested elsewhere)
      const AssociationResult r = d.associate(s.context(scan));
      for (std::size_t j = 0; j < where.size(); ++j) {
        if (gone[j]) continue;
        expected[j] += hit[j] ? 1 : -1;
        misses += !hit[j];
        const bool removed =
            std::find(r.remove.begin(), r.remove.end(), Scene::idOf(j)) != r.remove.end();
        ASSERT_EQ(removed, expected[j] <= 0) << "scan " << scan << " landmark " << j;
        if (removed) {
          gone[j] = true;
          ++removals;
        } else {
          ASSERT_EQ(d.evidence(Scene::idOf(j)), expected[j]) << "scan " << scan;
        }
      }
    }
    EXPECT_GT(misses, 10);
    EXPECT_GE(removals, 1);
  }
}

// Seen one scan in three: the paper's counter removes it; with P_D = 0.3 it stays (its hit rate
// 1/3 is above tau = 0.15) and its evidence grows.
TEST(DJNNDetection, LowDetectionProbabilityKeepsAnIntermittentLandmark) {
  auto run = [](const std::string& pd, int* final_evidence) {
    Scene s;
    const int a = s.addLandmark({10, 0});
    const int b = s.addLandmark({12, 6});
    s.build();
    DJNN d = makeDjnn({{"detection_probability", pd}});
    int removed_at = -1;
    for (int scan = 0; scan < 30 && removed_at < 0; ++scan) {
      clearScan(&s);
      s.observeLandmark(b);
      if (scan % 3 == 0) s.observeLandmark(a);
      const AssociationResult r = d.associate(s.context(scan));
      for (LandmarkId id : r.remove) {
        if (id == Scene::idOf(a)) removed_at = scan;
      }
    }
    *final_evidence = d.evidence(Scene::idOf(a));
    return removed_at;
  };
  int t = 0;
  EXPECT_GE(run("1", &t), 0);
  EXPECT_EQ(run("0.3", &t), -1);
  // 10 hits of +1.7 and 20 misses of -0.3 from 2: 13.
  EXPECT_EQ(t, 13);
}

// The weights: tau = (P_D + P_F) / 2, hit +2 (1 - tau), miss -2 tau; clutter raises tau.
TEST(DJNNDetection, WeightsFollowDetectionAndClutter) {
  auto after = [](const std::map<std::string, std::string>& p, int hits, int misses) {
    Scene s;
    const int a = s.addLandmark({10, 0});
    const int b = s.addLandmark({12, 6});
    s.build();
    DJNN d = makeDjnn(p);
    for (int k = 0; k < hits + misses; ++k) {
      clearScan(&s);
      s.observeLandmark(b);
      if (k < hits) s.observeLandmark(a);
      d.associate(s.context(k));
    }
    return d.evidence(Scene::idOf(a));
  };
  // P_D = 0.4: tau = 0.2: 2 + 5 * 1.6 - 5 * 0.4 = 8. The counter alone: without the profile's
  // extensions (the density test would withdraw pairings among that much clutter).
  EXPECT_EQ(after({{"detection_probability", "0.4"}, {"missed_detection_profile", "false"}}, 5, 5),
            8);
  // Strong clutter (P_F capped at P_D / 2 = 0.2): tau = 0.3: 2 + 5 * 1.4 - 5 * 0.6 = 6.
  EXPECT_EQ(after({{"detection_probability", "0.4"},
                   {"clutter_density", "1000"},
                   {"missed_detection_profile", "false"}},
                  5, 5),
            6);
}

// A feature seen, missed, and seen again: the paper drops it at the miss (T = 0); with P_D = 0.5
// (tau = 0.25) T = 1.5 - 0.5 + 1.5 = 2.5 admits it on the second sighting.
TEST(DJNNDetection, TentativeFeatureSurvivesAMissAtLowDetectionProbability) {
  auto decisions = [](const std::string& pd) {
    Scene s;
    const int b = s.addLandmark({12, 6});
    s.build();
    DJNN d = makeDjnn({{"detection_probability", pd}});
    std::vector<Decision> out;
    for (int k = 0; k < 3; ++k) {
      clearScan(&s);
      s.observeLandmark(b);
      if (k != 1) s.observePoint({8, -3});
      const AssociationResult r = d.associate(s.context(k));
      if (k != 1) out.push_back(r.decision.back());
    }
    return out;
  };
  EXPECT_EQ(decisions("1"), (std::vector<Decision>{Decision::kTentative, Decision::kTentative}));
  EXPECT_EQ(decisions("0.5"), (std::vector<Decision>{Decision::kTentative, Decision::kNew}));
}

// Lost scans' looks at a landmark, one per character: 'H' seen, 'm' missed inside the penalty
// region, '.' not seen and outside it.
std::vector<LostLook> lostLooks(const std::string& seq) {
  std::vector<LostLook> looks;
  for (const char c : seq) {
    LostLook l;
    l.seen = c == 'H';
    l.in_sensor = c == '.' ? Eigen::Vector2d(100.0, 0.0) : Eigen::Vector2d(10.0, 1.0);
    looks.push_back(l);
  }
  return looks;
}

// At a fix the pipeline hands DJNN each landmark it mapped from the lost scans with what every
// lost scan saw (DataAssociation::landmarkFromLostScans). DJNN counts its evidence over them as
// tracking would have: from the first sighting, +1 seen and -1 missed inside the penalty region
// (P_D = 1), admitted at admit_evidence, removed at remove_evidence. Kept only if it ends admitted.
TEST(DJNNDetection, LostScansAreWeighedByTheEvidenceTrackingWouldHaveCounted) {
  const auto replay = [](const std::string& seq, LandmarkId id, DJNN* d) {
    return d->landmarkFromLostScans(id, assoc_test::diag2(0.01, 0.01), lostLooks(seq));
  };
  DJNN d = makeDjnn();  // admit_evidence 2, remove_evidence 0
  EXPECT_TRUE(replay("HHHm", 1, &d));
  EXPECT_EQ(d.evidence(1), 2);
  EXPECT_FALSE(replay("HHmm", 2, &d));   // admitted, then missed back to 0: removed
  EXPECT_TRUE(replay("mmmHH", 3, &d));   // misses before its first sighting do not count
  EXPECT_TRUE(replay("HH...", 4, &d));   // nor those outside the penalty region
  EXPECT_FALSE(replay("H....", 5, &d));  // seen once: still tentative
  EXPECT_TRUE(replay("HmHH", 6, &d));    // dropped while tentative, started again, admitted
  EXPECT_EQ(d.evidence(6), 2);
}

// A landmark of the map before, still recent when the lost scans began: its evidence goes on over
// them as tracking would have counted it (DataAssociation::landmarkOverLostScans).
TEST(DJNNDetection, ARecentLandmarkIsWeighedOnOverTheLostScans) {
  const auto replay = [](const std::string& seq, LandmarkId id, DJNN* d) {
    return d->landmarkOverLostScans(id, assoc_test::diag2(0.01, 0.01), lostLooks(seq));
  };
  DJNN d = makeDjnn();  // admit_evidence 2, remove_evidence 0
  d.landmarkLoaded(1, 2);
  d.landmarkLoaded(2, 2);
  d.landmarkLoaded(3, 2);
  EXPECT_TRUE(replay("mH", 1, &d));  // missed once, seen again
  EXPECT_EQ(d.evidence(1), 2);
  EXPECT_FALSE(replay("mmH", 2, &d));  // missed down to 0: removed (the sighting after is late)
  EXPECT_TRUE(replay("..m", 3, &d));   // outside the penalty region nothing counts
  EXPECT_EQ(d.evidence(3), 1);
}

// The sensor region of eq. 9 honours the minimum range and the polygon: landmarks closer than
// min_range or outside the polygon are not penalised; one inside it is.
TEST(DJNNDetection, MinimumRangeAndPolygonBoundThePenaltyRegion) {
  Scene s;
  const int seen = s.addLandmark({3, 0});
  const int near = s.addLandmark({0.5, 0});  // closer than min_range 0.8
  const int side = s.addLandmark({2, 2.5});  // in the half-plane, outside the trapezoid
  const int inside = s.addLandmark({4, 1});  // in the trapezoid, never observed
  s.build();
  DJNN d = makeDjnn({{"sensor_range", "5"},
                     {"range_margin", "0.3"},
                     {"angle_margin", "0.02"},
                     {"min_range", "0.8"},
                     {"fov_polygon", "0.8,-0.5; 4.5,-1.5; 4.5,1.5; 0.8,0.5"},
                     {"initial_evidence", "5"}});
  s.observeLandmark(seen);
  for (int k = 0; k < 3; ++k) d.associate(s.context(k));
  EXPECT_EQ(d.evidence(Scene::idOf(near)), 5);
  EXPECT_EQ(d.evidence(Scene::idOf(side)), 5);
  EXPECT_EQ(d.evidence(Scene::idOf(inside)), 2);
  EXPECT_EQ(d.evidence(Scene::idOf(seen)), 8);
}

// Issue 31: a user states the sensor's detection probability; DJNN switches on the extensions a
// sensor that misses landmarks needs, without configuring them one by one. A value the user sets
// wins; a sensor that sees everything reads the documented defaults (the paper's DJNN).
TEST(DJNNDetection, MissedDetectionProfileIsOnBelowDetectionProbabilityOne) {
  const DJNN all_seen = makeDjnn();
  EXPECT_FALSE(all_seen.params().follow_pose.tentative_follow_pose);
  EXPECT_FALSE(all_seen.params().density.density_test);
  EXPECT_EQ(all_seen.params().bias.bias_keep_pairings, 0);

  const DJNN camera = makeDjnn({{"detection_probability", "0.7"}});
  EXPECT_TRUE(camera.params().follow_pose.tentative_follow_pose);
  EXPECT_TRUE(camera.params().static_test.static_heading);
  EXPECT_TRUE(camera.params().density.density_test);
  EXPECT_EQ(camera.params().bias.bias_keep_pairings, 10);
  EXPECT_EQ(camera.params().remembered.remembered_sightings, 2);
  EXPECT_EQ(camera.params().remembered.held_birth_cost, 4.0);
  EXPECT_EQ(camera.params().confirmation.held_confirmations, 1);

  const DJNN told = makeDjnn({{"detection_probability", "0.7"},
                              {"tentative_follow_pose", "false"},
                              {"held_confirmations", "0"}});
  EXPECT_FALSE(told.params().follow_pose.tentative_follow_pose);
  EXPECT_EQ(told.params().confirmation.held_confirmations, 0);
  EXPECT_TRUE(told.params().density.density_test);

  const DJNN bare =
      makeDjnn({{"detection_probability", "0.7"}, {"missed_detection_profile", "false"}});
  EXPECT_FALSE(bare.params().follow_pose.tentative_follow_pose);
  EXPECT_EQ(bare.params().confirmation.held_confirmations, 0);
}

// The exact bound the switch uses: closed forms at no hit (1 - 0.01^(1/n)) and at one miss
// (0.99^(1/n)), the normal approximation for many looks, 1 without misses.
TEST(DJNNDetection, BinomialUpperBoundIsClopperPearson) {
  EXPECT_NEAR(binomialUpperBound(0, 2, 0.99), 0.9, 1e-9);
  EXPECT_NEAR(binomialUpperBound(0, 10, 0.99), 1.0 - std::pow(0.01, 0.1), 1e-9);
  EXPECT_NEAR(binomialUpperBound(9, 10, 0.99), std::pow(0.99, 0.1), 1e-9);
  EXPECT_NEAR(binomialUpperBound(700, 1000, 0.99), 0.7 + 2.326 * std::sqrt(0.21 / 1000), 0.003);
  EXPECT_EQ(binomialUpperBound(10, 10, 0.99), 1.0);
  EXPECT_EQ(binomialUpperBound(0, 0, 0.99), 1.0);
  EXPECT_LT(binomialUpperBound(60, 100, 0.99), binomialUpperBound(60, 90, 0.99));
}

// P_D not set (docs/djnn.md, "P_D estimated online"): twelve landmarks in view, each seen with
// probability `rate` per scan. A sensor that misses a third of them is found to (once, with a
// notice), and from then DJNN counts with the estimate and has the missed-detection profile on; one
// that misses few stays the paper's, P_D 1 and the plain parameters. A stated P_D is never
// estimated.
TEST(DJNNDetection, DetectionProbabilityNotSetIsEstimatedFromTheMap) {
  auto run = [](double rate, const std::map<std::string, std::string>& params, int* notices,
                int* switched_at) {
    Scene s;
    for (int k = 0; k < 12; ++k) s.addLandmark({8.0 + 1.5 * k, -6.0 + (k % 4) * 4.0});
    s.build();
    DJNN d = makeDjnn(params);
    std::mt19937 rng(11);
    *notices = 0;
    *switched_at = -1;
    for (int scan = 0; scan < 80; ++scan) {
      clearScan(&s);
      for (int k = 0; k < 12; ++k) {
        if (std::bernoulli_distribution(rate)(rng)) s.observeLandmark(k);
      }
      if (s.observations.empty()) continue;
      const AssociationResult r = d.associate(s.context(0.1 * scan));
      if (!r.notice.empty()) {
        ++*notices;
        *switched_at = scan;
      }
    }
    return d;
  };
  int notices = 0, at = -1;
  const DJNN camera = run(0.6, {{"detection_probability", ""}}, &notices, &at);
  EXPECT_EQ(notices, 1);
  EXPECT_GE(at, 0);
  EXPECT_LT(at, 20);
  EXPECT_TRUE(camera.detectionEstimate().switched());
  EXPECT_NEAR(camera.detectionProbability(), 0.6, 0.08);
  EXPECT_TRUE(camera.params().follow_pose.tentative_follow_pose);
  EXPECT_TRUE(camera.params().static_test.static_heading);
  EXPECT_EQ(camera.params().bias.bias_keep_pairings, 10);
  EXPECT_EQ(camera.params().confirmation.held_confirmations, 1);

  const DJNN laser = run(0.97, {{"detection_probability", ""}}, &notices, &at);
  EXPECT_EQ(notices, 0);
  EXPECT_TRUE(laser.detectionEstimate().on());
  EXPECT_FALSE(laser.detectionEstimate().switched());
  EXPECT_GT(laser.detectionEstimate().looks(), 500.0);
  EXPECT_EQ(laser.detectionProbability(), 1.0);
  EXPECT_FALSE(laser.params().follow_pose.tentative_follow_pose);
  EXPECT_EQ(laser.params().bias.bias_keep_pairings, 0);

  const DJNN stated = run(0.6, {{"detection_probability", "1"}}, &notices, &at);
  EXPECT_EQ(notices, 0);
  EXPECT_FALSE(stated.detectionEstimate().on());
  EXPECT_EQ(stated.detectionProbability(), 1.0);
  EXPECT_FALSE(stated.params().follow_pose.tentative_follow_pose);

  // The user's own values win over the profile's at the switch too.
  const DJNN told =
      run(0.6, {{"detection_probability", ""}, {"tentative_follow_pose", "false"}}, &notices, &at);
  EXPECT_TRUE(told.detectionEstimate().switched());
  EXPECT_FALSE(told.params().follow_pose.tentative_follow_pose);
  EXPECT_TRUE(told.params().static_test.static_heading);

  EXPECT_THROW(makeDjnn({{"detection_switch_level", "1.5"}}), ParameterError);
}

// Loop closures are decided jointly whatever the sensor (6 Dec 2026: in djnn_strong a walker
// entering the range beside an old landmark closed the loop on its own): the density of unmapped
// landmarks is estimated and the joint decision is on by default, for P_D = 1 too. Without any
// density of "not in the map" the default is off; loop_closure_age set then is an error.
TEST(DJNNDetection, LoopClosuresAreDecidedJointlyForEverySensor) {
  const DJNN all_seen;
  EXPECT_TRUE(all_seen.params().density.estimate_landmark_density);
  EXPECT_EQ(all_seen.params().joint.loop_closure_age, 60.0);
  EXPECT_FALSE(all_seen.params().density.density_test);  // ordinary scans: not by default
  DJNN given;                                            // ... unless the density is given
  given.configure(
      MapParameterSource(std::map<std::string, std::string>{{"landmark_density", "0.3"}}));
  EXPECT_TRUE(given.params().density.density_test);
  DJNN camera;
  camera.configure(
      MapParameterSource(std::map<std::string, std::string>{{"detection_probability", "0.7"}}));
  EXPECT_EQ(camera.params().joint.loop_closure_age, 60.0);
  DJNN no_density;
  no_density.configure(MapParameterSource(
      std::map<std::string, std::string>{{"estimate_landmark_density", "false"}}));
  EXPECT_EQ(no_density.params().joint.loop_closure_age, 0.0);
  DJNN d;
  EXPECT_THROW(d.configure(MapParameterSource(std::map<std::string, std::string>{
                   {"estimate_landmark_density", "false"}, {"loop_closure_age", "60"}})),
               ParameterError);
  EXPECT_NO_THROW(d.configure(MapParameterSource(std::map<std::string, std::string>{
      {"estimate_landmark_density", "false"}, {"clutter_density", "0.01"}})));
  EXPECT_EQ(d.params().joint.loop_closure_age, 60.0);
}

// The density of unmapped landmarks is estimated from the map: landmarks on a 3 m grid
// (1/9 per m^2) all around; the sensor's half disc of 30 m holds about 157 of them.
TEST(DJNNDetection, LandmarkDensityIsEstimatedFromTheMappedLandmarksInView) {
  Scene s;
  for (double x = -45.0; x <= 45.0; x += 3.0) {
    for (double y = -45.0; y <= 45.0; y += 3.0) s.addLandmark({x + 0.5, y + 0.5});
  }
  s.build();
  s.observePoint({8.0, 1.0}, nullptr, 0);
  DJNN estimating =
      makeDjnn({{"detection_probability", "0.7"}, {"estimate_landmark_density", "true"}});
  EXPECT_EQ(estimating.landmarkDensity(), 0.0);  // nothing seen yet: off
  estimating.associate(s.context());
  EXPECT_NEAR(estimating.landmarkDensity(), 1.0 / 9.0, 0.05 / 9.0);

  DJNN given = makeDjnn({{"detection_probability", "0.7"}, {"landmark_density", "0.3"}});
  given.associate(s.context());
  EXPECT_EQ(given.landmarkDensity(), 0.3);

  DJNN paper = makeDjnn();  // the paper's DJNN: no density test
  paper.associate(s.context());
  EXPECT_EQ(paper.landmarkDensity(), 0.0);
}

}  // namespace test_djnn_detection
}  // namespace ekf_slam
