// Tests of the ACFR tree extractor: synthetic scans rendered analytically, and real Victoria Park
// scans checked against ACFR's published detections.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ekf_slam/core/feature_extraction/tree_extractor.h"
#include "ekf_slam/data/victoria_park.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_tree_extractor {

constexpr int kBeams = 361;
// As in a sensor_msgs/LaserScan of the converted bag (float32 fields).
const double kAngleMin = static_cast<float>(-M_PI / 2);
const double kIncrement = static_cast<float>(M_PI / 360);
constexpr double kDeg = M_PI / 180.0;
const float kInf = std::numeric_limits<float>::infinity();

struct Circle {
  double range;    // of the centre
  double bearing;  // LaserScan convention
  double diameter;
};

// Ranges of a scan that sees only the given circles (nearest hit per ray); `background` elsewhere.
std::vector<float> render(const std::vector<Circle>& circles, float background = kInf) {
  std::vector<float> ranges(kBeams, background);
  for (int i = 0; i < kBeams; ++i) {
    const double a = kAngleMin + i * kIncrement;
    const double ux = std::cos(a), uy = std::sin(a);
    for (const Circle& c : circles) {
      const double cx = c.range * std::cos(c.bearing), cy = c.range * std::sin(c.bearing);
      const double b = cx * ux + cy * uy;
      const double disc = b * b - (cx * cx + cy * cy - c.diameter * c.diameter / 4);
      if (disc < 0 || b <= 0) continue;
      const double t = b - std::sqrt(disc);
      if (t < ranges[i]) ranges[i] = static_cast<float>(t);
    }
  }
  return ranges;
}

// The scanner's 1 cm resolution, as in the data set.
std::vector<float> toCentimetres(std::vector<float> r) {
  for (float& v : r) {
    if (std::isfinite(v)) v = static_cast<float>(std::round(v * 100.0) / 100.0);
  }
  return r;
}

std::vector<DetectedTree> detect(const std::vector<float>& ranges) {
  return TreeExtractor().extract(ranges, kAngleMin, kIncrement);
}

// A single trunk is found at its centre. The method's biases: the diameter counts one extra beam
// width and the edge beams graze the trunk (longer ranges), so allow about a beam width at range.
TEST(TreeExtractor, SingleCircle) {
  for (const Circle c : {Circle{10.0, 20 * kDeg, 0.5}, Circle{25.0, -40 * kDeg, 0.8},
                         Circle{4.0, 75 * kDeg, 0.3}, Circle{40.0, 0.0, 1.0}}) {
    SCOPED_TRACE(::testing::Message() << "range " << c.range << " diameter " << c.diameter);
    const auto trees = detect(toCentimetres(render({c})));
    ASSERT_EQ(trees.size(), 1u);
    const double beam_width = c.range * 0.5 * kDeg;
    EXPECT_NEAR(trees[0].range, c.range, 0.05 + beam_width);
    EXPECT_NEAR(trees[0].bearing, c.bearing, 0.3 * kDeg);
    EXPECT_NEAR(trees[0].diameter, c.diameter, 0.02 + beam_width);
    EXPECT_LE(trees[0].first_beam, trees[0].last_beam);
    // The reported beams are the ones that hit the trunk.
    const double mid = (trees[0].first_beam + trees[0].last_beam) / 2.0;
    EXPECT_NEAR(kAngleMin + mid * kIncrement, trees[0].bearing, 1e-6);
  }
}

TEST(TreeExtractor, TwoTrees) {
  const auto trees =
      detect(toCentimetres(render({{8.0, -30 * kDeg, 0.4}, {15.0, 30 * kDeg, 0.6}})));
  ASSERT_EQ(trees.size(), 2u);
  EXPECT_NEAR(trees[0].bearing, -30 * kDeg, 0.3 * kDeg);  // in beam order
  EXPECT_NEAR(trees[0].range, 8.0, 0.1);
  EXPECT_NEAR(trees[1].bearing, 30 * kDeg, 0.3 * kDeg);
  EXPECT_NEAR(trees[1].range, 15.0, 0.15);
}

TEST(TreeExtractor, SameResultForDoubleAndFloatGeometry) {
  // The reader's double increment and a bag's float32 one give the same trees (bearings differ
  // only by the float rounding of angle_min).
  const auto r = toCentimetres(render({{12.0, 10 * kDeg, 0.5}, {30.0, -60 * kDeg, 0.7}}));
  const auto a = TreeExtractor().extract(r, -M_PI / 2, M_PI / 360);
  const auto b = detect(r);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(a[k].first_beam, b[k].first_beam);
    EXPECT_EQ(a[k].last_beam, b[k].last_beam);
    EXPECT_DOUBLE_EQ(a[k].range, b[k].range);
    EXPECT_DOUBLE_EQ(a[k].diameter, b[k].diameter);
    EXPECT_NEAR(a[k].bearing, b[k].bearing, 1e-7);
  }
}

TEST(TreeExtractor, ReversedBeamOrder) {
  std::vector<float> r = toCentimetres(render({{10.0, 25 * kDeg, 0.5}}));
  const auto forward = detect(r);
  std::vector<float> reversed(r.rbegin(), r.rend());
  const auto backward = TreeExtractor().extract(reversed, -kAngleMin, -kIncrement);
  ASSERT_EQ(forward.size(), 1u);
  ASSERT_EQ(backward.size(), 1u);
  EXPECT_NEAR(backward[0].bearing, forward[0].bearing, 1e-6);
  EXPECT_DOUBLE_EQ(backward[0].range, forward[0].range);
}

TEST(TreeExtractor, WallIsNotATree) {
  // A straight wall 6 m ahead across the whole field of view: one long segment.
  std::vector<float> r(kBeams);
  for (int i = 0; i < kBeams; ++i) {
    const double a = kAngleMin + i * kIncrement;
    r[i] = std::cos(a) > 0.1 ? static_cast<float>(6.0 / std::cos(a)) : kInf;
  }
  EXPECT_TRUE(detect(toCentimetres(r)).empty());
}

TEST(TreeExtractor, LongObjectIsNotATree) {
  // A 3 m wide object (a car) at 10 m is too wide, though it is a compact segment.
  EXPECT_TRUE(detect(toCentimetres(render({{10.0, 0.0, 3.0}}))).empty());
}

TEST(TreeExtractor, OccludedTreeAndOccluderAreDropped) {
  // A pole 2 m in front of a trunk and beside it in angle: the segment ends are within 3 m, so the
  // detector cannot tell what is hidden and drops both.
  const Circle tree{9.0, 0.0, 0.6};
  const Circle pole{7.0, 2.5 * kDeg, 0.2};
  ASSERT_EQ(detect(toCentimetres(render({tree}))).size(), 1u);  // each alone is a tree
  ASSERT_EQ(detect(toCentimetres(render({pole}))).size(), 1u);
  EXPECT_TRUE(detect(toCentimetres(render({tree, pole}))).empty());
}

TEST(TreeExtractor, FartherOfAdjacentSegmentsIsDropped) {
  // Two trunks 10 m apart in range, the far one partly hidden behind the near one: their
  // segments are adjacent beams, so the far one (maybe cut) is dropped and the near one kept.
  const Circle near{6.0, 0.0, 0.4};
  const double overlap = std::asin(0.2 / 6.0) + std::asin(0.3 / 16.0) - 0.8 * kDeg;
  for (const double side : {-1.0, 1.0}) {
    const auto trees = detect(toCentimetres(render({near, {16.0, side * overlap, 0.6}})));
    ASSERT_EQ(trees.size(), 1u);
    EXPECT_NEAR(trees[0].range, 6.0, 0.1);
  }
  // Apart by more than a degree, both are trees.
  const double apart = std::asin(0.2 / 6.0) + std::asin(0.3 / 16.0) + 2.0 * kDeg;
  EXPECT_EQ(detect(toCentimetres(render({near, {16.0, apart, 0.6}}))).size(), 2u);
}

TEST(TreeExtractor, NoReturns) {
  EXPECT_TRUE(detect(std::vector<float>(kBeams, 81.91f)).empty());
  EXPECT_TRUE(detect(std::vector<float>(kBeams, kInf)).empty());
}

TEST(TreeExtractor, InvalidRangesGiveNothing) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const float bad : {nan, kInf, -kInf, -3.0f, 0.0f}) {
    EXPECT_TRUE(detect(std::vector<float>(kBeams, bad)).empty());
  }
  // Bad beams around a real trunk neither crash nor create trees; the trunk is still found.
  std::vector<float> r = toCentimetres(render({{10.0, 0.0, 0.5}}));
  for (int i = 0; i < kBeams; i += 7) {
    if (!std::isfinite(r[i]) || r[i] > 20) r[i] = (i % 3 == 0) ? nan : (i % 3 == 1 ? -1.0f : -kInf);
  }
  const auto trees = detect(r);
  ASSERT_EQ(trees.size(), 1u);
  EXPECT_NEAR(trees[0].range, 10.0, 0.15);
  // Garbage geometry gives nothing rather than nonsense.
  EXPECT_TRUE(TreeExtractor().extract(r, std::nan(""), kIncrement).empty());
}

TEST(TreeExtractor, NegativeRangesDoNotHideATrunk) {
  // ACFR keeps negative ranges (only r < 75 is tested); here they are no return, so junk beams
  // next to a trunk cannot make it look like the farther of two neighbours.
  std::vector<float> r = toCentimetres(render({{10.0, 0.0, 0.5}}));
  const auto clean = detect(r);
  ASSERT_EQ(clean.size(), 1u);
  r[clean[0].first_beam - 1] = r[clean[0].first_beam - 2] = -1.0f;
  r[clean[0].last_beam + 1] = -0.5f;
  const auto trees = detect(r);
  ASSERT_EQ(trees.size(), 1u);
  EXPECT_DOUBLE_EQ(trees[0].range, clean[0].range);
}

TEST(TreeExtractor, CentimetreTiesFollowAcfr) {
  // 16.04 - 14.54 is exactly 1.5 in ACFR's doubles (no split: a valid 3-beam tree), but 1.5000010
  // between the float32 ranges (a split into three pieces that the clutter rule removes).
  std::vector<float> r(kBeams, kInf);
  r[180] = r[182] = 14.54f;
  r[181] = 16.04f;
  const auto trees = detect(r);
  ASSERT_EQ(trees.size(), 1u);
  const double d = (M_PI / 360 * 2 + M_PI / 360) * (14.54 + 14.54) / 2;
  EXPECT_NEAR(trees[0].diameter, d, 1e-12);  // exact cm doubles, not float32 ranges (4e-7 off)
  EXPECT_NEAR(trees[0].range, 16.04 + d / 2, 1e-12);
  TreeExtractorParams raw;
  raw.range_resolution = 0.0;
  EXPECT_TRUE(TreeExtractor(raw).extract(r, kAngleMin, kIncrement).empty());
}

TEST(TreeExtractor, EmptyAndTinyInput) {
  EXPECT_TRUE(detect({}).empty());
  EXPECT_TRUE(detect({5.0f}).empty());  // a single beam is at both edges of its field of view
}

TEST(TreeExtractor, TreeAtTheEdgeOfTheFieldOfViewIsRejected) {
  // Within 5*pi/306 rad (2.94 deg) of an edge a trunk may be cut by the field of view.
  EXPECT_TRUE(detect(toCentimetres(render({{10.0, kAngleMin + 1.5 * kDeg, 0.3}}))).empty());
  EXPECT_TRUE(detect(toCentimetres(render({{10.0, -kAngleMin - 1.5 * kDeg, 0.3}}))).empty());
  EXPECT_EQ(detect(toCentimetres(render({{10.0, kAngleMin + 8 * kDeg, 0.3}}))).size(), 1u);
  EXPECT_EQ(detect(toCentimetres(render({{10.0, -kAngleMin - 8 * kDeg, 0.3}}))).size(), 1u);
}

TEST(TreeExtractor, TooCloseAndTooFarAreRejected) {
  EXPECT_TRUE(detect(toCentimetres(render({{1.0, 0.0, 0.2}}))).empty());   // first range < 1 m
  EXPECT_TRUE(detect(toCentimetres(render({{76.0, 0.0, 1.0}}))).empty());  // beyond 75 m
}

TEST(TreeExtractor, CsvRows) {
  std::ostringstream out;
  writeTreesCsvHeader(out);
  writeTreesCsvRows(out, 7, 21.819, {{10.5, -0.25, 0.3, 100, 104}});
  EXPECT_EQ(out.str(),
            "scan,stamp,range,bearing,diameter\n7,21.819000,10.500000,-0.250000,0.300000\n");
}

// ---------------------------------------------------------------------------------------------
// Real scans. Expected values: ACFR's detectTreesI16 output for the original aa3_lsr2.mat as
// published in kykleung/RFS-SLAM data/VictoriaPark/measurements.dat (5 decimals; bearing from the
// vehicle's right, 0..pi). Scans 36, 3501 and 7185 contain threshold ties whose outcome depends on
// ACFR's double rounding (a "clean" tie rule finds one more tree in each).

class VictoriaParkScans : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string dir = victoria_park::defaultDataDir();
    if (!std::filesystem::exists(dir + "/victoria_park_ascii/LASER.txt")) return;
    laser_ = std::make_unique<victoria_park::LaserScans>(victoria_park::loadLaser(dir));
  }
  static void TearDownTestSuite() { laser_.reset(); }
  void SetUp() override {
    if (!laser_) EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found (set VP_DATA)");
  }
  static std::unique_ptr<victoria_park::LaserScans> laser_;
};
std::unique_ptr<victoria_park::LaserScans> VictoriaParkScans::laser_;

struct Published {
  double range, bearing, diameter;
};

void expectPublished(const std::vector<float>& ranges, const std::vector<Published>& expected) {
  // ACFR's frame: beam 0 at bearing 0.
  const auto trees = TreeExtractor().extract(ranges, 0.0, M_PI / 360);
  ASSERT_EQ(trees.size(), expected.size());
  for (size_t k = 0; k < trees.size(); ++k) {
    SCOPED_TRACE(::testing::Message() << "tree " << k);
    EXPECT_NEAR(trees[k].range, expected[k].range, 6e-6);
    EXPECT_NEAR(trees[k].bearing, expected[k].bearing, 6e-6);
    EXPECT_NEAR(trees[k].diameter, expected[k].diameter, 6e-6);
  }
  // The bag's geometry (float32, LaserScan convention) finds the same trees.
  const auto bag = TreeExtractor().extract(ranges, kAngleMin, kIncrement);
  ASSERT_EQ(bag.size(), trees.size());
  for (size_t k = 0; k < trees.size(); ++k) {
    EXPECT_DOUBLE_EQ(bag[k].range, trees[k].range);
    EXPECT_NEAR(bag[k].bearing, trees[k].bearing - M_PI / 2, 1e-7);
  }
}

TEST_F(VictoriaParkScans, PublishedDetections) {
  ASSERT_EQ(laser_->ranges.size(), 7230u);
  EXPECT_EQ(laser_->time_ms[0], 21819);  // t_ascii 0.852
  expectPublished(laser_->ranges[0], {{20.46202, 0.88575, 0.35404},
                                      {29.59859, 1.02102, 0.25717},
                                      {28.68462, 1.27409, 0.24923},
                                      {12.74537, 1.35263, 0.11074},
                                      {23.96735, 1.48789, 0.41469},
                                      {24.59350, 1.81078, 0.84701},
                                      {12.68386, 1.90677, 0.43773},
                                      {3.13945, 2.81434, 0.10891}});
  expectPublished(laser_->ranges[36], {{44.92517, 0.21817, 0.39034},
                                       {29.96927, 0.24871, 0.51854},
                                       {15.16609, 0.48869, 0.39218},
                                       {23.04989, 0.79412, 0.59978},
                                       {20.97214, 1.12574, 0.54428},
                                       {31.22009, 1.15628, 0.54018},
                                       {15.57878, 1.40063, 0.53756},
                                       {16.40288, 1.91114, 0.70577},
                                       {5.24537, 2.41292, 0.45073}});
  expectPublished(
      laser_->ranges[3501],
      {{6.42055, 0.17017, 0.11109}, {48.27766, 1.28718, 0.83531}, {30.09073, 2.72271, 0.26145}});
  expectPublished(laser_->ranges[7185], {{6.27824, 0.74613, 0.74648},
                                         {11.45883, 1.21300, 0.29767},
                                         {15.48728, 1.28282, 0.13456},
                                         {28.68462, 1.35263, 0.24923},
                                         {43.99561, 1.66243, 0.76123},
                                         {26.47907, 1.72351, 0.45815},
                                         {17.71500, 1.80205, 0.60999},
                                         {9.04584, 2.01149, 0.62169},
                                         {19.41434, 2.68781, 0.16869}});
}

TEST_F(VictoriaParkScans, WholeDataSet) {
  // 52792 = the number of rows of the published measurements.dat that fall on the 7230 scans of
  // the ASCII release (its detections up to t = 1545.182 s). The sums come from an independent
  // vectorised re-run of detectTreesI16 (numpy) that matches measurements.dat.
  const TreeExtractor extractor;
  const auto start = std::chrono::steady_clock::now();
  size_t trees = 0;
  double range_sum = 0, bearing_sum = 0, diameter_sum = 0;
  long beam_sum = 0;
  for (const auto& ranges : laser_->ranges) {
    for (const DetectedTree& t : extractor.extract(ranges, 0.0, M_PI / 360)) {
      ++trees;
      range_sum += t.range;
      bearing_sum += t.bearing;
      diameter_sum += t.diameter;
      beam_sum += t.first_beam + t.last_beam;
    }
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::cout << "[ INFO     ] " << laser_->ranges.size() << " scans, " << trees << " trees, " << ms
            << " ms (" << 1000.0 * ms / laser_->ranges.size() << " us per scan)\n";
  EXPECT_EQ(trees, 52792u);
  EXPECT_EQ(beam_sum, 19647710);
  EXPECT_NEAR(range_sum, 1297812.980866, 1e-5);
  EXPECT_NEAR(bearing_sum, 85729.307494, 1e-5);
  EXPECT_NEAR(diameter_sum, 24042.541732, 1e-5);
}

}  // namespace test_tree_extractor
}  // namespace ekf_slam
