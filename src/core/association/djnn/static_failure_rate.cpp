#include "ekf_slam/core/association/djnn/static_failure_rate.h"

#include <cmath>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

void StaticFailureRate::configure(double size, double horizon) {
  size_ = size;
  horizon_ = horizon;
  z_ = std::sqrt(chi2Quantile(0.998, 1));  // one-sided 99.9 %
  reset();
}

void StaticFailureRate::reset() {
  tests_ = failures_ = 0.0;
  last_stamp_ = 0.0;
  started_ = false;
}

void StaticFailureRate::tested(bool failed, double stamp) {
  // Movers come and go: the share is of the recent tests, forgotten over the horizon.
  if (started_ && horizon_ > 0.0 && stamp > last_stamp_) {
    const double keep = std::exp(-(stamp - last_stamp_) / horizon_);
    tests_ *= keep;
    failures_ *= keep;
  }
  if (!started_ || stamp > last_stamp_) last_stamp_ = stamp;
  started_ = true;
  tests_ += 1.0;
  if (failed) failures_ += 1.0;
}

bool StaticFailureRate::moversRuledOut() const {
  if (!(tests_ > 0.0)) return false;
  const double n = tests_;
  const double p = failures_ / n;
  const double z2 = z_ * z_;
  const double upper =
      (p + z2 / (2.0 * n) + z_ * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n))) /
      (1.0 + z2 / n);
  return upper < size_;
}

}  // namespace ekf_slam
