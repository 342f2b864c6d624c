#include "ekf_slam/core/association/djnn/detection_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ekf_slam {

namespace {

constexpr double kConfidence = 0.99;

// The regularised incomplete beta function I_x(a, b), by its continued fraction (modified Lentz),
// taken on the side where it converges fast.
double incompleteBeta(double x, double a, double b) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  if (x > (a + 1.0) / (a + b + 2.0)) return 1.0 - incompleteBeta(1.0 - x, b, a);
  const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) +
                                a * std::log(x) + b * std::log1p(-x)) /
                       a;
  constexpr double kTiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  d = 1.0 / (std::abs(d) < kTiny ? kTiny : d);
  double f = d;
  for (int m = 1; m <= 300; ++m) {
    for (int odd = 0; odd < 2; ++odd) {
      const double num = odd == 0 ? m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m))
                                  : -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1));
      d = 1.0 + num * d;
      d = 1.0 / (std::abs(d) < kTiny ? kTiny : d);
      c = 1.0 + num / c;
      if (std::abs(c) < kTiny) c = kTiny;
      f *= c * d;
      if (odd == 1 && std::abs(c * d - 1.0) < 1e-12) return front * f;
    }
  }
  return front * f;
}

}  // namespace

double binomialUpperBound(double hits, double looks, double confidence) {
  if (!(looks > 0.0) || hits >= looks) return 1.0;
  // Clopper-Pearson: the p at which `hits` or fewer of `looks` has probability 1 - confidence,
  // the quantile of Beta(hits + 1, looks - hits); bisection on its increasing CDF.
  const double a = hits + 1.0, b = looks - hits;
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (incompleteBeta(mid, a, b) < confidence ? lo : hi) = mid;
  }
  return hi;
}

void DetectionEstimate::read(const ParameterReader& r) {
  p_.detection_switch_level =
      r.inRange("detection_switch_level", Params().detection_switch_level, 0.0, 1.0);
}

void DetectionEstimate::configure(bool on) {
  on_ = on;
  reset();
}

void DetectionEstimate::reset() {
  switched_ = false;
  looks_ = hits_ = 0.0;
}

double DetectionEstimate::upperBound() const {
  return binomialUpperBound(hits_, looks_, kConfidence);
}

bool DetectionEstimate::observe(const AssociationContext& ctx, const DjnnPaper& paper,
                                const LocalScan& scan, const AssociationResult& result) {
  if (!on_ || scan.held) return false;
  for (int k = 0; k < scan.candidates(); ++k) {
    const LandmarkId id = ctx.landmarkId(scan.cand[k]);
    if (std::find(result.remove.begin(), result.remove.end(), id) != result.remove.end()) continue;
    // The looks the paper's evidence step counts a miss for.
    if (!paper.looksAt(ctx, scan, k)) continue;
    looks_ += scan.detectableAt(k);
    if (scan.count[k] > 0) hits_ += 1.0;
  }
  // The bound is never below the rate itself: no bisection while the rate is above the level.
  if (switched_ || estimate() >= p_.detection_switch_level) return false;
  if (!(upperBound() < p_.detection_switch_level)) return false;
  switched_ = true;
  return true;
}

std::string DetectionEstimate::notice() const {
  char text[400];
  std::snprintf(text, sizeof text,
                "DJNN: detection_probability is not set, and the map's landmarks in view were "
                "detected in %.0f %% of %.0f looks: the sensor misses landmarks. From now on P_D "
                "is estimated online and the missed-detection profile is on (docs/djnn.md). Set "
                "detection_probability to the sensor's value to start that way.",
                100.0 * estimate(), looks_);
  return text;
}

}  // namespace ekf_slam
