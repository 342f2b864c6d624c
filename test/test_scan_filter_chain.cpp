// The scan filter chain: each filter's effect, laser_filters' YAML shape, errors.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "ekf_slam/app/scan_filter_yaml.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"

namespace test_scan_filter_chain {

using namespace ekf_slam;

// 5 beams at -90, -45, 0, 45, 90 deg, ranges 1..5, intensities 100, 200, ...
LaserScanData fiveBeams() {
  LaserScanData s;
  s.angle_min = -M_PI / 2;
  s.angle_increment = M_PI / 4;
  s.ranges = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f};
  s.intensities = {100.0f, 200.0f, 300.0f, 400.0f, 500.0f};
  s.range_min = 0.5;
  s.range_max = 4.5;
  return s;
}

ScanFilterSpec spec(const std::string& type, std::map<std::string, std::string> params) {
  return {"f", type, std::move(params)};
}

std::vector<bool> kept(const LaserScanData& s) {
  std::vector<bool> out;
  for (const float r : s.ranges) out.push_back(std::isfinite(r));
  return out;
}

LaserScanData filtered(const ScanFilterSpec& sp, const Eigen::Vector3d& offset = {0, 0, 0}) {
  LaserScanData s = fiveBeams();
  ScanFilterChain::fromSpecs({sp}).apply(&s, offset);
  return s;
}

TEST(ScanFilterChain, RangeBounds) {
  const auto s = filtered(spec("laser_filters/LaserScanRangeFilter",
                               {{"lower_threshold", "1.5"}, {"upper_threshold", "4.0"}}));
  EXPECT_EQ(kept(s), (std::vector<bool>{false, true, true, false, false}));
  const auto m =
      filtered(spec("laser_filters/LaserScanRangeFilter", {{"use_message_range_limits", "true"}}));
  EXPECT_EQ(kept(m), (std::vector<bool>{true, true, true, true, false}));
  const auto r = filtered(spec("laser_filters/LaserScanRangeFilter",
                               {{"upper_threshold", "4.0"}, {"upper_replacement_value", "99"}}));
  EXPECT_FLOAT_EQ(r.ranges[4], 99.0f);
}

TEST(ScanFilterChain, AngularBounds) {
  const auto s = filtered(spec("laser_filters/LaserScanAngularBoundsFilterInPlace",
                               {{"lower_angle", "-1.0"}, {"upper_angle", "0.5"}}));
  EXPECT_EQ(kept(s), (std::vector<bool>{false, true, true, false, false}));
  EXPECT_EQ(s.ranges.size(), 5u);  // in place: the geometry stays
}

TEST(ScanFilterChain, IntensityBounds) {
  const auto s = filtered(spec("laser_filters/LaserScanIntensityFilter",
                               {{"lower_threshold", "150"}, {"upper_threshold", "450"}}));
  EXPECT_EQ(kept(s), (std::vector<bool>{false, true, true, true, false}));
  const auto inv =
      filtered(spec("laser_filters/LaserScanIntensityFilter",
                    {{"lower_threshold", "150"}, {"upper_threshold", "450"}, {"invert", "true"}}));
  EXPECT_EQ(kept(inv), (std::vector<bool>{true, false, false, false, true}));
}

TEST(ScanFilterChain, IntensityFilterNeedsIntensities) {
  const ScanFilterChain chain = ScanFilterChain::fromSpecs(
      {spec("laser_filters/LaserScanIntensityFilter", {{"lower_threshold", "150"}})});
  EXPECT_TRUE(chain.needsIntensities());
  LaserScanData s = fiveBeams();
  s.intensities.clear();
  EXPECT_THROW(chain.apply(&s, Eigen::Vector3d::Zero()), ScanFormatError);
}

TEST(ScanFilterChain, BoxMasksTheVehicleInTheBaseFrame) {
  // Box [-3, 2.5] x [-1.5, 1.5] in base_link; the laser sits 2 m ahead, looking forward. In
  // base_link the beams end at (2, -1), (3.41, -1.41), (5, 0), (4.83, 2.83), (2, 5): only the
  // first lies in the box.
  const ScanFilterSpec box = spec("laser_filters/LaserScanBoxFilter", {{"box_frame", "base_link"},
                                                                       {"min_x", "-3"},
                                                                       {"max_x", "2.5"},
                                                                       {"min_y", "-1.5"},
                                                                       {"max_y", "1.5"},
                                                                       {"min_z", "-1"},
                                                                       {"max_z", "1"}});
  const auto s = filtered(box, Eigen::Vector3d(2.0, 0.0, 0.0));
  EXPECT_EQ(kept(s), (std::vector<bool>{false, true, true, true, true}));
  // With the laser at the origin, beam 1 ends at (1.41, -1.41): in the box too.
  const auto at_origin = filtered(box);
  EXPECT_EQ(kept(at_origin), (std::vector<bool>{false, false, true, true, true}));
}

TEST(ScanFilterChain, UnknownTypeListsTheKnownOnes) {
  try {
    ScanFilterChain::fromSpecs({spec("laser_filters/LaserScanSpeckleFilter", {})});
    FAIL() << "unknown type accepted";
  } catch (const ParameterError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("LaserScanSpeckleFilter"), std::string::npos) << what;
    for (const std::string& t : ScanFilterChain::knownTypes())
      EXPECT_NE(what.find(t), std::string::npos) << what;
  }
}

TEST(ScanFilterChain, MisspeltParameterIsAnError) {
  try {
    ScanFilterChain::fromSpecs(
        {spec("laser_filters/LaserScanRangeFilter", {{"lower_treshold", "1"}})});
    FAIL() << "misspelt parameter accepted";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find("lower_treshold"), std::string::npos) << e.what();
  }
  EXPECT_THROW(
      ScanFilterChain::fromSpecs({spec("laser_filters/LaserScanRangeFilter",
                                       {{"lower_threshold", "5"}, {"upper_threshold", "1"}})}),
      ParameterError);
}

TEST(ScanFilterChain, FromLaserFiltersYaml) {
  const auto specs = readScanFilterChainText(R"(
sigma_range: 0.5
scan_filter_chain:
  - name: range
    type: laser_filters/LaserScanRangeFilter
    params:
      lower_threshold: 1.5
      upper_threshold: 4.0
  - name: angle
    type: laser_filters/LaserScanAngularBoundsFilterInPlace
    params: {lower_angle: -1.0, upper_angle: 1.0}
)");
  ASSERT_EQ(specs.size(), 2u);
  EXPECT_EQ(specs[0].name, "range");
  EXPECT_EQ(specs[1].params.at("upper_angle"), "1.0");
  LaserScanData s = fiveBeams();
  const ScanFilterChain chain = ScanFilterChain::fromSpecs(specs);
  EXPECT_EQ(chain.names(), (std::vector<std::string>{"range", "angle"}));
  chain.apply(&s, Eigen::Vector3d::Zero());
  EXPECT_EQ(kept(s), (std::vector<bool>{false, true, true, false, false}));

  EXPECT_TRUE(readScanFilterChainText("sigma_range: 0.5\n").empty());
  EXPECT_THROW(readScanFilterChainText("scan_filter_chain: {name: a}\n"), ParameterError);
  EXPECT_THROW(readScanFilterChainText("scan_filter_chain:\n  - {name: a, type: b, parms: {}}\n"),
               ParameterError);
}

}  // namespace test_scan_filter_chain
