// Shape context descriptors; see the header for the rotation-invariance argument.
#include "ekf_slam/core/graph_matching/shape_context.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace ekf_slam {
namespace {

constexpr double kBinWidth = 2.0 * M_PI / kShapeContextAngleBins;

// Adds `weight` at angle `angle` (radians, any value) of distance ring `ring`, split linearly
// between the two nearest angle bins (bin k is centred on k * 30 deg).
void addSoft(int ring, double angle, double weight, ShapeContext* h) {
  double t = angle / kBinWidth;
  // Wrap to [0, 12]. The angle is a difference of two atan2 values, so |t| < 24, where counting
  // the thresholds passed gives floor(t / 12) exactly (no double lies within rounding of them)
  // and, once t >= 0, truncation gives floor(t): std::floor's values without a division.
  constexpr double kTurn = kShapeContextAngleBins;
  if (std::abs(t) < 2.0 * kTurn) {
    t -= kTurn * (static_cast<double>(t >= kTurn) - static_cast<double>(t < 0.0) -
                  static_cast<double>(t < -kTurn));
  } else {
    t -= kTurn * std::floor(t / kTurn);
  }
  const int whole = static_cast<int>(t);
  const int lo = whole % kShapeContextAngleBins;
  const int hi = (lo + 1) % kShapeContextAngleBins;
  const double f = t - whole;
  (*h)[ring * kShapeContextAngleBins + lo] += weight * (1.0 - f);
  (*h)[ring * kShapeContextAngleBins + hi] += weight * f;
}

// 0.5 sum (a - b)^2 / (a + b) over the bins of two histograms of any size.
template <typename Histogram>
double chiSquare(const Histogram& a, const Histogram& b) {
  double sum = 0.0;
  for (int k = 0; k < a.size(); ++k) {
    const double s = a[k] + b[k];
    if (s > 0.0) sum += (a[k] - b[k]) * (a[k] - b[k]) / s;
  }
  return 0.5 * sum;
}

// Bit masks of the first and the last angle bin of every ring.
constexpr std::uint64_t ringBits(int angle_bin) {
  std::uint64_t m = 0;
  for (int ring = 0; ring < kShapeContextDistanceBins; ++ring) {
    m |= std::uint64_t{1} << (ring * kShapeContextAngleBins + angle_bin);
  }
  return m;
}
constexpr std::uint64_t kRingFirstBits = ringBits(0);
constexpr std::uint64_t kRingLastBits = ringBits(kShapeContextAngleBins - 1);

// kShiftedBin[s][k]: the bin of `b` that bin k of `a` meets under angle shift s - 1.
struct ShiftedBins {
  int bin[3][kShapeContextBins];
  constexpr ShiftedBins() : bin() {
    for (int s = 0; s < 3; ++s) {
      for (int k = 0; k < kShapeContextBins; ++k) {
        const int ring = k / kShapeContextAngleBins;
        const int angle =
            (k % kShapeContextAngleBins + s - 1 + kShapeContextAngleBins) % kShapeContextAngleBins;
        bin[s][k] = ring * kShapeContextAngleBins + angle;
      }
    }
  }
  constexpr const int* operator[](int s) const { return bin[s]; }
};
constexpr ShiftedBins kShiftedBin;

static_assert(kShapeContextBins <= 64, "the supports are 64-bit masks");

}  // namespace

void shapeContexts(const std::vector<Eigen::Vector2d>& points, const ShapeContextParams& params,
                   std::vector<ShapeContext>* out) {
  ShapeContextBuilder().build(points, params, out);
}

void ShapeContextBuilder::build(const std::vector<Eigen::Vector2d>& points,
                                const ShapeContextParams& params, std::vector<ShapeContext>* out) {
  const int n = static_cast<int>(points.size());
  out->assign(n, ShapeContext::Zero());
  work_.assign(n, Point{Eigen::Vector2d::Zero(), 0.0, 0.0});
  const double log_min = std::log(params.min_radius);
  const double ring_width =
      (std::log(params.max_radius) - log_min) / static_cast<double>(kShapeContextDistanceBins);
  // Each unordered pair once: the difference, its norm and its ring serve both points (negating
  // a difference is exact). Pairs are visited with i ascending, then k ascending, so every point
  // receives its neighbours' contributions in the order of their index, as a loop per point
  // would add them.
  const auto in_reach = [&](double r) { return !(r > params.max_radius || r <= 0.0); };
  ring_.resize(static_cast<std::size_t>(n) * (n > 0 ? n - 1 : 0) / 2);
  std::size_t pair = 0;  // index of (i, k) in the order visited
  for (int i = 0; i < n; ++i) {
    for (int k = i + 1; k < n; ++k, ++pair) {
      const Eigen::Vector2d d = points[k] - points[i];
      const double r = d.norm();
      ring_[pair] = -1;
      if (!in_reach(r)) continue;
      ring_[pair] = static_cast<signed char>(
          std::clamp(static_cast<int>(std::floor((std::log(r) - log_min) / ring_width)), 0,
                     kShapeContextDistanceBins - 1));
      // Reference direction: 1/d-weighted circular mean of the directions to the neighbours.
      const Eigen::Vector2d w = d / (r * std::max(r, params.min_radius));
      work_[i].resultant += w;
      work_[k].resultant -= w;
      work_[i].neighbours += 1.0;
      work_[k].neighbours += 1.0;
    }
  }
  // A perfectly balanced neighbourhood has no direction; its histogram is then (nearly)
  // symmetric as well, so the arbitrary x axis costs little.
  for (Point& q : work_) {
    q.reference =
        q.resultant.squaredNorm() > 1e-18 ? std::atan2(q.resultant.y(), q.resultant.x()) : 0.0;
  }
  pair = 0;
  for (int i = 0; i < n; ++i) {
    for (int k = i + 1; k < n; ++k, ++pair) {
      const int ring = ring_[pair];
      if (ring < 0) continue;
      const Eigen::Vector2d d = points[k] - points[i];
      addSoft(ring, std::atan2(d.y(), d.x()) - work_[i].reference, 1.0, &(*out)[i]);
      addSoft(ring, std::atan2(-d.y(), -d.x()) - work_[k].reference, 1.0, &(*out)[k]);
    }
  }
  for (int i = 0; i < n; ++i) {
    if (work_[i].neighbours > 0.0) (*out)[i] /= work_[i].neighbours;
  }
}

double chiSquareDistance(const ShapeContext& a, const ShapeContext& b) { return chiSquare(a, b); }

ShapeContextSupport shapeContextSupport(const ShapeContext& h) {
  ShapeContextSupport s;
  for (int k = 0; k < kShapeContextBins; ++k) {
    if (h[k] != 0.0) s.bins |= std::uint64_t{1} << k;
  }
  // Under shift s the term of bin k of `a` takes bin (k + s - 1) mod 12 of the same ring of `b`:
  // the mask of `b` rotated within each ring of 12 bits.
  const std::uint64_t m = s.bins;
  s.shifted[0] =
      ((m << 1) & ~kRingFirstBits) | ((m >> (kShapeContextAngleBins - 1)) & kRingFirstBits);
  s.shifted[1] = m;
  s.shifted[2] =
      ((m >> 1) & ~kRingLastBits) | ((m << (kShapeContextAngleBins - 1)) & kRingLastBits);
  s.sum = h.sum();
  return s;
}

double shapeContextDistance(const ShapeContext& a, const ShapeContext& b) {
  return shapeContextDistance(a, shapeContextSupport(a), b, shapeContextSupport(b));
}

double shapeContextDistance(const ShapeContext& a, const ShapeContextSupport& sa,
                            const ShapeContext& b, const ShapeContextSupport& sb) {
  // chi2 = 0.5 (sum a + sum b) - 2 sum_k a_k b_k / (a_k + b_k), where only the bins non-zero in
  // both contribute; they are visited in ascending order, as the dense sum adds them.
  double both[3] = {0.0, 0.0, 0.0};
  for (int s = 0; s < 3; ++s) {
    double acc = 0.0;
    for (std::uint64_t bits = sa.bins & sb.shifted[s]; bits != 0; bits &= bits - 1) {
      const int k = __builtin_ctzll(bits);
      const double x = a[k];
      const double y = b[kShiftedBin[s][k]];
      acc += x * y / (x + y + 1e-300);
    }
    both[s] = acc;
  }
  const double half_total = 0.5 * (sa.sum + sb.sum);
  return std::max(0.0, half_total - 2.0 * std::max({both[0], both[1], both[2]}));
}

RingHistogram ringHistogram(const ShapeContext& h) {
  RingHistogram r;
  for (int ring = 0; ring < kShapeContextDistanceBins; ++ring) {
    r[ring] = h.segment<kShapeContextAngleBins>(ring * kShapeContextAngleBins).sum();
  }
  return r;
}

double ringDistance(const RingHistogram& a, const RingHistogram& b) { return chiSquare(a, b); }

}  // namespace ekf_slam
