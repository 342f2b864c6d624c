// SensorModel: the region (range annulus, wedge, convex polygon) grown and shrunk by margins,
// clutter probability, polygon parsing and parameter validation.
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "ekf_slam/core/common/sensor_model.h"

namespace ekf_slam {
namespace test_sensor_model {

SensorModel read(const std::map<std::string, std::string>& p) {
  const MapParameterSource src(p);
  return readSensorModel(ParameterReader(src));
}

TEST(SensorModel, DefaultsAreAHalfDiscOf30m) {
  const SensorModel s = read({});
  EXPECT_DOUBLE_EQ(s.max_range, 30.0);
  EXPECT_DOUBLE_EQ(s.min_range, 0.0);
  EXPECT_DOUBLE_EQ(s.field_of_view, M_PI);
  EXPECT_DOUBLE_EQ(s.detection_probability, 1.0);
  EXPECT_DOUBLE_EQ(s.clutter_density, 0.0);
  EXPECT_TRUE(s.polygon.empty());
  EXPECT_TRUE(s.contains({10, 5}, 0, 0));
  EXPECT_FALSE(s.contains({-1, 5}, 0, 0));    // behind
  EXPECT_TRUE(s.contains({-1, 5}, 0, 2));     // ... within a 2 m lateral margin
  EXPECT_FALSE(s.contains({31, 0}, 0, 0));    // beyond R
  EXPECT_TRUE(s.contains({31, 0}, 3, 0));     // ... within R + d
  EXPECT_FALSE(s.contains({28, 0}, -3, 0));   // the shrunk region ends at R - d
  EXPECT_FALSE(s.contains({0.5, 3}, 0, -1));  // and 1 m inside the edges
  EXPECT_TRUE(s.contains({1.5, 3}, 0, -1));
}

TEST(SensorModel, MinimumRangeGrowsAndShrinksInwards) {
  const SensorModel s = read({{"min_range", "2"}, {"field_of_view", "6.283185307179586"}});
  EXPECT_FALSE(s.contains({1.5, 0}, 0, 0));
  EXPECT_TRUE(s.contains({2.5, 0}, 0, 0));
  EXPECT_TRUE(s.contains({1.5, 0}, 1, 0));    // grown: min range 1
  EXPECT_FALSE(s.contains({2.5, 0}, -1, 0));  // shrunk: min range 3
  EXPECT_TRUE(s.contains({-10, 0}, 0, 0));    // full circle: no wedge
}

TEST(SensorModel, TrapezoidPolygon) {
  // A downward camera: 0.8 .. 4.5 m ahead, 1 m wide at the near edge, 3 m at the far edge
  // (clockwise on purpose: either winding).
  const SensorModel s = read({{"sensor_range", "5"},
                              {"field_of_view", "6.283185307179586"},
                              {"fov_polygon", "0.8,-0.5; 0.8,0.5; 4.5,1.5; 4.5,-1.5"}});
  ASSERT_EQ(s.polygon.size(), 4u);
  EXPECT_TRUE(s.contains({2, 0}, 0, 0));
  EXPECT_TRUE(s.contains({4.4, 1.3}, 0, 0));
  EXPECT_FALSE(s.contains({0.5, 0}, 0, 0));  // before the near edge
  EXPECT_TRUE(s.contains({0.5, 0}, 0, 0.5));
  EXPECT_FALSE(s.contains({1.0, 0.9}, 0, 0));  // beside it
  EXPECT_FALSE(s.contains({2, 0}, 0, -1.5));   // the shrunk polygon is ~0.9 m wide there
  EXPECT_TRUE(s.contains({2.5, 0}, 0, -0.4));
  EXPECT_FALSE(s.contains({4.7, 0}, 0, 0));
}

TEST(SensorModel, FalseDetectionProbabilityIsPoisson) {
  SensorModel s;
  EXPECT_EQ(s.falseDetectionProbability(1.0), 0.0);
  s.clutter_density = 0.1;
  EXPECT_NEAR(s.falseDetectionProbability(2.0), 1.0 - std::exp(-0.2), 1e-15);
  EXPECT_EQ(s.falseDetectionProbability(0.0), 0.0);
}

TEST(SensorModel, ParsePolygon) {
  EXPECT_TRUE(parsePolygon("").empty());
  EXPECT_EQ(parsePolygon("0,0; 1,0; 0,1;").size(), 3u);
  EXPECT_THROW(parsePolygon("0,0; 1,0"), std::invalid_argument);
  EXPECT_THROW(parsePolygon("0 0; 1,0; 0,1"), std::invalid_argument);
  EXPECT_THROW(parsePolygon("0,0; 1,0; 0,1,2"), std::invalid_argument);
}

TEST(SensorModel, ParametersAreValidatedAndNamed) {
  const std::map<std::string, std::string> bad[] = {
      {{"min_range", "40"}},
      {{"min_range", "-1"}},
      {{"detection_probability", "0"}},
      {{"detection_probability", "1.5"}},
      {{"clutter_density", "-0.1"}},
      {{"field_of_view", "0"}},
      {{"fov_polygon", "1,0; 2,0"}},
      {{"fov_polygon", "1,0; 2,0; 3,0"}},        // no area
      {{"fov_polygon", "1,-1; 3,0; 1,1; 2,0"}},  // not convex
      {{"fov_polygon", "1,-1; 40,0; 1,1"}},      // beyond sensor_range
      {{"fov_polygon", "a,b; 1,1; 2,2"}},
  };
  for (const auto& p : bad) {
    try {
      read(p);
      ADD_FAILURE() << p.begin()->first << " = " << p.begin()->second << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find(p.begin()->first), std::string::npos) << e.what();
    }
  }
}

}  // namespace test_sensor_model
}  // namespace ekf_slam
