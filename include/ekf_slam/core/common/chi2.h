// Chi-square quantiles for the gates (chi2(d, 1 - alpha)). ROS-free.
#pragma once

#include <vector>

namespace ekf_slam {

/// P(X <= x) for X ~ chi2(dof).
double chi2Cdf(double x, int dof);
/// The x with chi2Cdf(x, dof) = probability, e.g. chi2Quantile(0.95, 2) = 5.991.
double chi2Quantile(double probability, int dof);

/// Quantiles for dof = 1..max_dof at one probability, computed once (JCBB needs chi2(2k)).
class Chi2Table {
 public:
  Chi2Table() = default;
  Chi2Table(double probability, int max_dof);
  double operator()(int dof) const;  ///< extends itself lazily past max_dof
  double probability() const { return probability_; }

 private:
  double probability_ = 0.95;
  mutable std::vector<double> q_;
};

}  // namespace ekf_slam
