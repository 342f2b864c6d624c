// The LaserScan geometry rule (scanGeometryError): consistent scans of real drivers pass, the
// faulty ones of issue 15 do not.
#include <cmath>

#include <gtest/gtest.h>

#include "ekf_slam/core/feature_extraction/scan_geometry.h"

namespace ekf_slam {
namespace test_scan_geometry {

constexpr double kInc = M_PI / 360;  // Victoria Park: 361 beams, -90..90 deg

TEST(ScanGeometry, ConsistentScansPass) {
  EXPECT_EQ(scanGeometryError(361, -M_PI / 2, M_PI / 2, kInc), nullptr);
  // angle_max one increment past the last beam (some drivers), float32 rounding.
  EXPECT_EQ(scanGeometryError(360, -M_PI / 2, M_PI / 2, kInc), nullptr);
  EXPECT_EQ(scanGeometryError(361, float(-M_PI / 2), float(M_PI / 2), float(kInc)), nullptr);
  // Clockwise scanners: a negative increment from angle_min > angle_max.
  EXPECT_EQ(scanGeometryError(361, M_PI / 2, -M_PI / 2, -kInc), nullptr);
  // A full turn.
  EXPECT_EQ(scanGeometryError(720, -M_PI, M_PI - kInc, kInc), nullptr);
  EXPECT_EQ(scanGeometryError(1, 0.3, 0.3, kInc), nullptr);
  EXPECT_EQ(scanGeometryError(0, -M_PI / 2, M_PI / 2, kInc), nullptr);  // empty: counted apart
}

TEST(ScanGeometry, InconsistentScansAreNamed) {
  const auto has = [](const char* error, const char* part) {
    return error != nullptr && std::string(error).find(part) != std::string::npos;
  };
  EXPECT_TRUE(has(scanGeometryError(3 * 361, -M_PI / 2, M_PI / 2, kInc), "number of ranges"));
  EXPECT_TRUE(has(scanGeometryError(362 + 2, -M_PI / 2, M_PI / 2, kInc), "number of ranges"));
  EXPECT_TRUE(has(scanGeometryError(361, -M_PI / 2, M_PI / 2, -kInc), "sign"));
  EXPECT_TRUE(has(scanGeometryError(361, -M_PI / 2, M_PI / 2, 1.0), "does not match"));
  EXPECT_TRUE(has(scanGeometryError(361, -M_PI / 2, M_PI / 2, 0.0), "zero"));
  EXPECT_TRUE(has(scanGeometryError(361, NAN, M_PI / 2, kInc), "non-finite"));
  EXPECT_TRUE(has(scanGeometryError(361, -M_PI / 2, INFINITY, kInc), "non-finite"));
  EXPECT_TRUE(has(scanGeometryError(361, -M_PI / 2, M_PI / 2, NAN), "non-finite"));
  EXPECT_TRUE(has(scanGeometryError(361, -100.0, 100.0, 200.0 / 360), "full turn"));
}

}  // namespace test_scan_geometry
}  // namespace ekf_slam
