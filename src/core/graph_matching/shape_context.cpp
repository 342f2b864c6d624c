// Shape context descriptors; see the header for the rotation-invariance argument.
#include "ekf_slam/core/graph_matching/shape_context.h"

#include <algorithm>
#include <cmath>

namespace ekf_slam {
namespace {

constexpr double kBinWidth = 2.0 * M_PI / kShapeContextAngleBins;

// Adds `weight` at angle `angle` (radians, any value) of distance ring `ring`, split linearly
// between the two nearest angle bins (bin k is centred on k * 30 deg).
void addSoft(int ring, double angle, double weight, ShapeContext* h) {
  double t = angle / kBinWidth;
  t -= kShapeContextAngleBins * std::floor(t / kShapeContextAngleBins);  // [0, 12)
  const int lo = static_cast<int>(t) % kShapeContextAngleBins;
  const int hi = (lo + 1) % kShapeContextAngleBins;
  const double f = t - std::floor(t);
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

}  // namespace

void shapeContexts(const std::vector<Eigen::Vector2d>& points, const ShapeContextParams& params,
                   std::vector<ShapeContext>* out) {
  const int n = static_cast<int>(points.size());
  out->assign(n, ShapeContext::Zero());
  const double log_min = std::log(params.min_radius);
  const double ring_width =
      (std::log(params.max_radius) - log_min) / static_cast<double>(kShapeContextDistanceBins);
  for (int i = 0; i < n; ++i) {
    // Reference direction: 1/d-weighted circular mean of the directions to the neighbours.
    Eigen::Vector2d resultant = Eigen::Vector2d::Zero();
    for (int k = 0; k < n; ++k) {
      if (k == i) continue;
      const Eigen::Vector2d d = points[k] - points[i];
      const double r = d.norm();
      if (r > params.max_radius || r <= 0.0) continue;
      resultant += d / (r * std::max(r, params.min_radius));
    }
    // A perfectly balanced neighbourhood has no direction; its histogram is then (nearly)
    // symmetric as well, so the arbitrary x axis costs little.
    const double reference =
        resultant.squaredNorm() > 1e-18 ? std::atan2(resultant.y(), resultant.x()) : 0.0;
    ShapeContext& h = (*out)[i];
    double total = 0.0;
    for (int k = 0; k < n; ++k) {
      if (k == i) continue;
      const Eigen::Vector2d d = points[k] - points[i];
      const double r = d.norm();
      if (r > params.max_radius || r <= 0.0) continue;
      const int ring =
          std::clamp(static_cast<int>(std::floor((std::log(r) - log_min) / ring_width)), 0,
                     kShapeContextDistanceBins - 1);
      addSoft(ring, std::atan2(d.y(), d.x()) - reference, 1.0, &h);
      total += 1.0;
    }
    if (total > 0.0) h /= total;
  }
}

double chiSquareDistance(const ShapeContext& a, const ShapeContext& b) { return chiSquare(a, b); }

double shapeContextDistance(const ShapeContext& a, const ShapeContext& b) {
  // chi2 = 0.5 (sum a + sum b) - 2 sum_k a_k b_k / (a_k + b_k) (terms where either is zero
  // vanish). b's rings are padded cyclically so the three shifts are contiguous, branch-free
  // loops the compiler vectorises.
  constexpr int kPad = kShapeContextAngleBins + 2;
  double padded[kShapeContextDistanceBins * kPad];
  for (int ring = 0; ring < kShapeContextDistanceBins; ++ring) {
    const double* src = b.data() + ring * kShapeContextAngleBins;
    double* dst = padded + ring * kPad;
    dst[0] = src[kShapeContextAngleBins - 1];
    for (int k = 0; k < kShapeContextAngleBins; ++k) dst[k + 1] = src[k];
    dst[kPad - 1] = src[0];
  }
  double both[3] = {0.0, 0.0, 0.0};
  for (int s = 0; s < 3; ++s) {
    double acc = 0.0;
    for (int ring = 0; ring < kShapeContextDistanceBins; ++ring) {
      const double* x = a.data() + ring * kShapeContextAngleBins;
      const double* y = padded + ring * kPad + s;
      for (int k = 0; k < kShapeContextAngleBins; ++k) {
        acc += x[k] * y[k] / (x[k] + y[k] + 1e-300);
      }
    }
    both[s] = acc;
  }
  const double half_total = 0.5 * (a.sum() + b.sum());
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
