// ACFR's Victoria Park tree-trunk detector (Guivant & Nebot), on a range array. ROS-free.
// Semantics follow ACFR's detectTreesI16.m step for step, including its floating-point arithmetic,
// so that the Victoria Park detections are bit-for-bit ACFR's; see docs/tree_extractor.md.
#pragma once

#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <vector>

namespace ekf_slam {

/// Thresholds of the detector; defaults are ACFR's values.
struct TreeExtractorParams {
  double max_range = 75.0;                ///< beams at or beyond this are discarded [m]
  double range_jump = 1.5;                ///< new segment when consecutive ranges differ more [m]
  double angle_gap = 5.0 * M_PI / 180.0;  ///< ... or when kept beams are further apart [rad]
  double occlusion_distance = 3.0;        ///< clutter: segment ends this close to a next start [m]
  int occlusion_lookahead = 3;            ///< ... among the next this many segments
  double neighbour_angle = 1.0 * M_PI / 180.0;  ///< closer segments: drop the farther [rad]
  double max_extent = 1.0;                      ///< max end-to-end distance of a trunk segment [m]
  double min_range = 1.0;                       ///< first range of a segment must exceed this [m]
  double edge_margin = 5.0 * M_PI / 306.0;      ///< min angle from each edge of the FOV [rad]
  /// Keep if |r_first - r_last| < d / divisor (ACFR divides by 3; a divisor, not a 1/3 factor,
  /// because d * (1/3) and d / 3 round differently).
  double max_range_difference_divisor = 3.0;
  /// Ranges are rounded to this step before use [m]; 0 uses them as given. ACFR's scanner reports
  /// whole centimetres and its code works on the doubles cm / 100; rounding float ranges (bag,
  /// reader) back to those doubles makes the ties (e.g. a jump of exactly 1.50 m) go ACFR's way.
  double range_resolution = 0.01;
};

/// One detected trunk. Bearing in the sensor frame (0 = x axis, counter-clockwise positive, as in
/// sensor_msgs/LaserScan); range to the trunk centre.
struct DetectedTree {
  double range;
  double bearing;
  double diameter;
  int first_beam;  ///< index of the segment's first beam in the input array
  int last_beam;   ///< index of its last beam
};

class TreeExtractor {
 public:
  explicit TreeExtractor(const TreeExtractorParams& p = TreeExtractorParams()) : p_(p) {}
  const TreeExtractorParams& params() const { return p_; }

  /// Beam i is at angle angle_min + i * angle_increment. Non-finite or non-positive ranges count
  /// as no return. An empty input gives no trees. When 180 deg / |angle_increment| is a whole
  /// number (within 1e-4: a float32 increment of 0.5 deg qualifies), beam angles are computed as
  /// ACFR's are, i * pi / that number. Thread-safe; reuses thread-local scratch buffers, so the
  /// only allocation per call (after the first) is the output.
  std::vector<DetectedTree> extract(const std::vector<float>& ranges, double angle_min,
                                    double angle_increment) const;

 private:
  TreeExtractorParams p_;
};

/// CSV output of detect_trees: header "scan,stamp,range,bearing,diameter" and one row per tree.
void writeTreesCsvHeader(std::ostream& out);
void writeTreesCsvRows(std::ostream& out, std::uint32_t scan, double stamp,
                       const std::vector<DetectedTree>& trees);

}  // namespace ekf_slam
