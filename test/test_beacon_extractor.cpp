// BeaconExtractor on synthetic scans: a ray-cast cylinder with high intensity on a dull wall.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "beacon_scans.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"

namespace test_beacon_extractor {

using namespace ekf_slam;
using Params = std::map<std::string, std::string>;
using beacon_scans::scanOf;

constexpr double kIncrement = M_PI / 360.0;  // 0.5 deg, 361 beams over 180 deg

BeaconExtractorParams withRadius(double r) {
  BeaconExtractorParams p;
  p.beacon_radius = r;
  return p;
}

TEST(BeaconExtractor, OneBeaconCentreBehindTheSurface) {
  const double radius = 0.1;
  const LaserScanData s = scanOf({{8.0, 2.0, radius, 5000.0}});
  const auto b = BeaconExtractor(withRadius(radius)).detect(s);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NEAR(b[0].range, std::hypot(8.0, 2.0), 0.03);
  EXPECT_NEAR(b[0].bearing, std::atan2(2.0, 8.0), 0.005);
  EXPECT_NEAR(b[0].width, 2 * radius, 0.08);
}

TEST(BeaconExtractor, WithoutTheRadiusTheRangeIsTheSurface) {
  const LaserScanData s = scanOf({{8.0, 2.0, 0.1, 5000.0}});
  const auto b = BeaconExtractor().detect(s);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_LT(b[0].range, std::hypot(8.0, 2.0) - 0.05);
}

TEST(BeaconExtractor, DullObjectsAreNotBeacons) {
  // A dull cylinder (a tree, a parked car's corner) and the dull wall: nothing.
  const LaserScanData s = scanOf({{6.0, -1.0, 0.2, 300.0}});
  EXPECT_TRUE(BeaconExtractor().detect(s).empty());
}

TEST(BeaconExtractor, TwoBeaconsAndWidthBounds) {
  const LaserScanData s =
      scanOf({{5.0, 3.0, 0.1, 5000.0}, {10.0, -4.0, 0.1, 5000.0}, {7.0, 0.0, 1.0, 5000.0}});
  const auto b = BeaconExtractor(withRadius(0.1)).detect(s);
  ASSERT_EQ(b.size(), 2u);  // the 2 m wide reflective drum is too wide
  EXPECT_NEAR(b[0].bearing, std::atan2(-4.0, 10.0), 0.01);
  EXPECT_NEAR(b[1].bearing, std::atan2(3.0, 5.0), 0.01);
}

TEST(BeaconExtractor, GapsAndRangeJumpsSplitGroups) {
  LaserScanData s = scanOf({{6.0, 0.0, 0.15, 5000.0}});
  // Dull out one beam inside the group: max_gap 1 keeps it together, 0 splits it.
  int first = -1, last = -1;
  for (int i = 0; i < static_cast<int>(s.ranges.size()); ++i) {
    if (s.intensities[i] > 1000.0f) {
      if (first < 0) first = i;
      last = i;
    }
  }
  ASSERT_GE(last - first, 2);
  s.intensities[(first + last) / 2] = 100.0f;
  BeaconExtractorParams p = withRadius(0.15);
  EXPECT_EQ(BeaconExtractor(p).detect(s).size(), 1u);
  p.max_gap = 0;
  p.min_width = 0.0;
  EXPECT_EQ(BeaconExtractor(p).detect(s).size(), 2u);
}

TEST(BeaconExtractor, RangeLimits) {
  const LaserScanData s = scanOf({{35.0, 0.0, 0.3, 5000.0}}, 60.0);
  EXPECT_TRUE(BeaconExtractor().detect(s).empty());  // max_range 30 m
  BeaconExtractorParams p;
  p.max_range = 40.0;
  EXPECT_EQ(BeaconExtractor(p).detect(s).size(), 1u);
}

TEST(BeaconExtractor, IntensityWeightedCentre) {
  LaserScanData s = scanOf({{6.0, 0.0, 0.15, 5000.0}});
  int last = 0;
  for (int i = 0; i < static_cast<int>(s.ranges.size()); ++i) {
    if (s.intensities[i] > 1000.0f) last = i;
  }
  s.intensities[last] = 50000.0f;  // the last beam dominates the weighted mean
  BeaconExtractorParams p;
  const double geometric = BeaconExtractor(p).detect(s).at(0).bearing;
  p.centre = "intensity";
  const double weighted = BeaconExtractor(p).detect(s).at(0).bearing;
  EXPECT_GT(weighted, geometric + 1e-4);
}

TEST(BeaconExtractor, ObservationNoiseFromTheGroup) {
  const LaserScanData s = scanOf({{8.0, 2.0, 0.1, 5000.0}});
  const auto obs = BeaconExtractor(withRadius(0.1)).extract(s);
  ASSERT_EQ(obs.size(), 1u);
  const BeaconExtractorParams p;
  EXPECT_GT(obs[0].R(0, 0), p.sigma_range * p.sigma_range);
  EXPECT_NEAR(obs[0].R(1, 1), p.sigma_bearing * p.sigma_bearing + kIncrement * kIncrement / 12,
              1e-12);
  EXPECT_EQ(obs[0].R(0, 1), 0.0);
  EXPECT_GT(obs[0].descriptor, 0.0);
}

TEST(BeaconExtractor, ScansWithoutIntensitiesAreAnError) {
  LaserScanData s = scanOf({{8.0, 2.0, 0.1, 5000.0}});
  s.intensities.clear();
  const BeaconExtractor e;
  EXPECT_TRUE(e.needsIntensities());
  try {
    e.checkScan(s);
    FAIL() << "no error for a scan without intensities";
  } catch (const ScanFormatError& err) {
    EXPECT_NE(std::string(err.what()).find("intensities"), std::string::npos);
  }
  s.intensities.assign(10, 1.0f);  // wrong length
  EXPECT_THROW(e.checkScan(s), ScanFormatError);
  EXPECT_TRUE(e.detect(s).empty());  // and never reads past the intensities
}

TEST(BeaconExtractor, BadBeamsAreNoReturn) {
  LaserScanData s = scanOf({{8.0, 2.0, 0.1, 5000.0}});
  for (std::size_t i = 0; i < s.ranges.size(); i += 7) s.ranges[i] = std::nanf("");
  s.ranges[3] = -1.0f;
  for (const Observation& o : BeaconExtractor(withRadius(0.1)).extract(s)) {
    EXPECT_TRUE(o.z.allFinite());
    EXPECT_TRUE(o.R.allFinite());
  }
  EXPECT_TRUE(BeaconExtractor().detect(LaserScanData()).empty());
}

TEST(BeaconExtractor, ConfigureValidates) {
  BeaconExtractor e;
  MapParameterSource p(Params{{"max_width", "0.01"}, {"min_width", "0.05"}}, "BeaconExtractor/");
  EXPECT_THROW(e.configure(p), ParameterError);
  MapParameterSource bad_centre(Params{{"centre", "median"}});
  EXPECT_THROW(e.configure(bad_centre), ParameterError);
  MapParameterSource ok(Params{{"beacon_radius", "0.05"}, {"intensity_threshold", "2000"}});
  e.configure(ok);
  EXPECT_DOUBLE_EQ(e.params().beacon_radius, 0.05);
  EXPECT_DOUBLE_EQ(e.params().intensity_threshold, 2000.0);
}

}  // namespace test_beacon_extractor
