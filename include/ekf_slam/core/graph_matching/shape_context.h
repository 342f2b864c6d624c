// Shape context node descriptors (Belongie, Malik & Puzicha 2002; seed 004 eq. 8-9): for each
// point of a set, a log-polar histogram of the other points around it, 12 angle bins of 30 deg x
// 5 log-distance bins, compared with the chi-square histogram distance.
//
// Rotation invariance: the angles of a point's histogram are measured from its own reference
// direction, the circular mean of the directions to its neighbours weighted by 1 / distance
// (near neighbours dominate, as in the log-polar bins). That direction turns with the set, so a
// rigid motion of the whole set leaves every descriptor unchanged. Occlusion of a neighbour can
// tilt the reference, so the angle bins are filled by linear interpolation (a tilt moves mass
// smoothly) and the distance takes the least chi-square over cyclic shifts of -1, 0, +1 angle bins.
// Distances are metric (no normalisation by the mean distance as in Belongie): a scan and the map
// share the same scale, while their extents differ.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

constexpr int kShapeContextAngleBins = 12;
constexpr int kShapeContextDistanceBins = 5;
constexpr int kShapeContextBins = kShapeContextAngleBins * kShapeContextDistanceBins;

/// Normalised histogram (sums to 1; all zero for a point with no neighbour in reach), bin
/// index = distance_bin * 12 + angle_bin.
using ShapeContext = Eigen::Matrix<double, kShapeContextBins, 1>;

struct ShapeContextParams {
  /// Log-distance bins span [min_radius, max_radius] [m]; closer neighbours fall in the first
  /// ring, farther ones are left out (a scan sees less of the world than the map holds).
  double min_radius = 2.0;
  double max_radius = 100.0;
};

/// Descriptor of every point of `points` (O(n^2)); `out` is resized.
void shapeContexts(const std::vector<Eigen::Vector2d>& points, const ShapeContextParams& params,
                   std::vector<ShapeContext>* out);

/// shapeContexts() keeping its per-point workspace between calls (no allocation once warm).
class ShapeContextBuilder {
 public:
  void build(const std::vector<Eigen::Vector2d>& points, const ShapeContextParams& params,
             std::vector<ShapeContext>* out);

 private:
  struct Point {
    Eigen::Vector2d resultant;  ///< 1/d-weighted sum of the directions to the neighbours
    double reference = 0.0;     ///< its angle
    double neighbours = 0.0;    ///< in reach
  };
  std::vector<Point> work_;
  std::vector<signed char> ring_;  ///< per pair of points: its log-distance ring, -1 out of reach
};

/// Chi-square histogram distance 0.5 sum (a - b)^2 / (a + b) over the bins, in [0, 1].
double chiSquareDistance(const ShapeContext& a, const ShapeContext& b);

/// The descriptor distance used for matching: least chi-square over the cyclic angle shifts
/// -1, 0, +1 of `b` (tolerates a reference direction tilted by up to one bin).
double shapeContextDistance(const ShapeContext& a, const ShapeContext& b);

/// What shapeContextDistance() needs of a histogram besides its bins, computed once per
/// histogram: its sum and its non-zero bins as bit masks (bit = bin index), as they line up with
/// the other histogram's bins under each angle shift. A chi-square term vanishes where either bin
/// is zero and about two thirds of the bins are empty, so the distance visits only the bins
/// non-zero in both (the same sum, term for term, as visiting all).
struct ShapeContextSupport {
  std::uint64_t bins = 0;         ///< as the first argument
  std::uint64_t shifted[3] = {};  ///< as the second argument, shift -1, 0, +1
  double sum = 0.0;
};
ShapeContextSupport shapeContextSupport(const ShapeContext& h);

/// shapeContextDistance(a, b) with the supports of a and b precomputed.
double shapeContextDistance(const ShapeContext& a, const ShapeContextSupport& sa,
                            const ShapeContext& b, const ShapeContextSupport& sb);

/// The histogram summed over angles: one value per log-distance ring (rotation invariant).
using RingHistogram = Eigen::Matrix<double, kShapeContextDistanceBins, 1>;
RingHistogram ringHistogram(const ShapeContext& h);

/// Chi-square distance of the ring histograms: a lower bound of shapeContextDistance() (merging
/// bins cannot increase a chi-square distance, and the rings do not depend on the angle shift),
/// so candidate search can skip full comparisons that cannot win.
double ringDistance(const RingHistogram& a, const RingHistogram& b);

}  // namespace ekf_slam
