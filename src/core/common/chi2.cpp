// Chi-square CDF and quantiles for any degree of freedom, from the regularised lower incomplete
// gamma function P(k/2, x/2) (series below a + 1, Lentz continued fraction for Q above), and a
// safeguarded Newton iteration for the quantile. No boost: the core stays Eigen-only.
#include "ekf_slam/core/common/chi2.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ekf_slam {
namespace {

constexpr double kEps = 1e-16;
constexpr int kMaxIterations = 1000;

// ln of the common factor x^a e^-x / Gamma(a).
double logPrefactor(double a, double x) { return a * std::log(x) - x - std::lgamma(a); }

// P(a, x) by its power series, converging fast for x < a + 1.
double gammaPSeries(double a, double x) {
  double term = 1.0 / a;
  double sum = term;
  for (int n = 1; n < kMaxIterations; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * kEps) break;
  }
  return sum * std::exp(logPrefactor(a, x));
}

// Q(a, x) = 1 - P(a, x) by its continued fraction (modified Lentz), for x >= a + 1.
double gammaQContinuedFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / kTiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < kEps) break;
  }
  return std::exp(logPrefactor(a, x)) * h;
}

// Upper tail Q(k/2, x/2), accurate also when it is tiny (needed for probabilities near 1).
double chi2Survival(double x, int dof) {
  if (x <= 0.0) return 1.0;
  const double a = 0.5 * dof, h = 0.5 * x;
  return h < a + 1.0 ? 1.0 - gammaPSeries(a, h) : gammaQContinuedFraction(a, h);
}

double chi2Density(double x, int dof) {
  if (x <= 0.0) return 0.0;
  const double a = 0.5 * dof;
  return 0.5 * std::exp((a - 1.0) * std::log(0.5 * x) - 0.5 * x - std::lgamma(a));
}

void checkDof(int dof) {
  if (dof < 1) throw std::invalid_argument("chi2: dof must be >= 1, got " + std::to_string(dof));
}

}  // namespace

double chi2Cdf(double x, int dof) {
  checkDof(dof);
  if (!(x > 0.0)) return 0.0;
  if (std::isinf(x)) return 1.0;
  const double a = 0.5 * dof, h = 0.5 * x;
  return h < a + 1.0 ? gammaPSeries(a, h) : 1.0 - gammaQContinuedFraction(a, h);
}

double chi2Quantile(double probability, int dof) {
  checkDof(dof);
  if (!(probability > 0.0 && probability < 1.0)) {
    if (probability == 0.0) return 0.0;
    if (probability == 1.0) return std::numeric_limits<double>::infinity();
    throw std::invalid_argument("chi2Quantile: probability must lie in [0, 1]");
  }
  // Wilson-Hilferty start: chi2 ~ k (1 - 2/9k + z sqrt(2/9k))^3, z the normal quantile (from a
  // rational approximation good to ~1e-3, plenty for a start).
  const double p_low = std::min(probability, 1.0 - probability);
  const double t = std::sqrt(-2.0 * std::log(p_low));
  double z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) /
                     (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t);
  if (probability < 0.5) z = -z;
  const double k = dof;
  const double w = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
  double x = k * w * w * w;
  if (!(x > 0.0)) x = 0.5 * k * probability + 1e-3;

  // Newton on F(x) - p, bracketed by bisection so it cannot leave (lo, hi). Works on the upper
  // tail when p is close to 1 so the residual keeps its relative precision.
  const double q = 1.0 - probability;
  const bool upper = probability > 0.5;
  double lo = 0.0, hi = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 200; ++i) {
    const double residual = upper ? q - chi2Survival(x, dof) : chi2Cdf(x, dof) - probability;
    if (residual < 0.0) {
      lo = x;  // F(x) < p: the root lies above
    } else {
      hi = x;
    }
    const double f = chi2Density(x, dof);
    double next = f > 0.0 ? x - residual / f : x;
    if (!(next > lo && next < hi)) next = std::isinf(hi) ? 2.0 * x + 1.0 : 0.5 * (lo + hi);
    if (std::fabs(next - x) <= 1e-14 * std::max(1.0, x)) return next;
    x = next;
  }
  return x;
}

Chi2Table::Chi2Table(double probability, int max_dof) : probability_(probability) {
  if (!(probability > 0.0 && probability < 1.0)) {
    throw std::invalid_argument("Chi2Table: probability must lie in (0, 1)");
  }
  q_.reserve(max_dof > 0 ? max_dof : 0);
  for (int d = 1; d <= max_dof; ++d) q_.push_back(chi2Quantile(probability_, d));
}

double Chi2Table::operator()(int dof) const {
  checkDof(dof);
  while (static_cast<int>(q_.size()) < dof) {
    q_.push_back(chi2Quantile(probability_, static_cast<int>(q_.size()) + 1));
  }
  return q_[dof - 1];
}

}  // namespace ekf_slam
