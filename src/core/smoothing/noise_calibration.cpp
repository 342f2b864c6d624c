#include "ekf_slam/core/smoothing/noise_calibration.h"

#include <cmath>

#include <Eigen/Cholesky>

namespace ekf_slam {

const char* noiseTermName(NoiseTerm term) {
  switch (term) {
    case NoiseTerm::kOdometryTranslation:
      return "odometry translation";
    case NoiseTerm::kOdometryRotation:
      return "odometry rotation";
    case NoiseTerm::kRange:
      return "range";
    case NoiseTerm::kBearing:
      return "bearing";
    case NoiseTerm::kOwnRange:
      return "range (own covariance)";
    case NoiseTerm::kOwnBearing:
      return "bearing (own covariance)";
    case NoiseTerm::kOwnX:
      return "x (own covariance)";
    case NoiseTerm::kOwnY:
      return "y (own covariance)";
    case NoiseTerm::kCount:
      break;
  }
  return "?";
}

namespace {

// A residual's covariance as `fixed` plus a share per calibrated term (at most two terms; an
// observation's in the top-left 2x2).
struct Split {
  Eigen::Matrix3d fixed = Eigen::Matrix3d::Zero();
  std::array<int, 2> term{{-1, -1}};
  std::array<Eigen::Matrix3d, 2> share{{Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()}};
  int dim = 3;

  Eigen::Matrix3d covariance(const std::array<double, kNoiseTerms>& theta) const {
    Eigen::Matrix3d C = fixed;
    for (int k = 0; k < 2; ++k)
      if (term[k] >= 0) C += theta[term[k]] * share[k];
    return C;
  }
};

Split odometrySplit(const SmoothingScan& s) {
  Split out;
  out.term = {static_cast<int>(NoiseTerm::kOdometryTranslation),
              static_cast<int>(NoiseTerm::kOdometryRotation)};
  out.share = {s.motion_translation, s.motion_rotation};
  out.fixed = s.motion_covariance - s.motion_translation - s.motion_rotation;
  return out;
}

// The default covariance is diag(sigma_range^2, sigma_bearing^2), carried to (x, y) at the point
// for a Cartesian observation (ObservationBuilder): one share per sigma. An observation's own
// covariance R is split per coordinate as d R / d log(theta_k) = (E_k R + R E_k) / 2, which keeps
// the sum R when it is correlated.
Split observationSplit(const SmoothingObservation& o, const NoiseCalibrationParams& p) {
  Split out;
  out.dim = 2;
  const bool cartesian = o.kind == MeasurementKind::kCartesian;
  if (o.default_covariance) {
    out.term = {static_cast<int>(NoiseTerm::kRange), static_cast<int>(NoiseTerm::kBearing)};
    Eigen::Matrix2d J = Eigen::Matrix2d::Identity();
    if (cartesian) {
      const double r = o.z.norm();
      const double c = r > 0.0 ? o.z.x() / r : 1.0, s = r > 0.0 ? o.z.y() / r : 0.0;
      J << c, -r * s, s, r * c;
    }
    const double var[2] = {p.sigma_range * p.sigma_range, p.sigma_bearing * p.sigma_bearing};
    for (int k = 0; k < 2; ++k)
      out.share[k].topLeftCorner<2, 2>() = var[k] * J.col(k) * J.col(k).transpose();
  } else {
    out.term = cartesian ? std::array<int, 2>{{static_cast<int>(NoiseTerm::kOwnX),
                                               static_cast<int>(NoiseTerm::kOwnY)}}
                         : std::array<int, 2>{{static_cast<int>(NoiseTerm::kOwnRange),
                                               static_cast<int>(NoiseTerm::kOwnBearing)}};
    for (int k = 0; k < 2; ++k) {
      Eigen::Matrix2d E = Eigen::Matrix2d::Zero();
      E(k, k) = 1.0;
      out.share[k].topLeftCorner<2, 2>() = 0.5 * (E * o.R + o.R * E);
    }
  }
  out.fixed.topLeftCorner<2, 2>() =
      o.R - out.share[0].topLeftCorner<2, 2>() - out.share[1].topLeftCorner<2, 2>();
  return out;
}

// Each term's weighted cost and its expected value, summed over the residuals.
struct TermSums {
  std::array<double, kNoiseTerms> cost{}, expected{}, trace{};
  std::array<std::size_t, kNoiseTerms> residuals{};
};

void accumulate(const Split& split, const SmoothingResidual& r,
                const std::array<double, kNoiseTerms>& theta, TermSums* sums) {
  const int d = split.dim;
  // The weight the smoother used: an odometry link's covariance floored as it floors it (a
  // standstill has no lateral noise).
  Eigen::MatrixXd C = split.covariance(theta).topLeftCorner(d, d);
  if (r.observation < 0) C.diagonal().array() += SmootherParams().min_variance;
  const Eigen::MatrixXd W = C.ldlt().solve(Eigen::MatrixXd::Identity(d, d));
  if (!W.allFinite() || !r.leverage.allFinite()) return;
  const Eigen::VectorXd Wv = W * r.v.head(d);
  const Eigen::MatrixXd WH = W * r.leverage.topLeftCorner(d, d);
  for (int k = 0; k < 2; ++k) {
    const int t = split.term[k];
    if (t < 0) continue;
    const Eigen::MatrixXd S = theta[t] * split.share[k].topLeftCorner(d, d);
    if (S.isZero(0.0)) continue;
    const Eigen::MatrixXd WS = W * S;
    sums->cost[t] += Wv.dot(S * Wv);
    sums->trace[t] += WS.trace();
    // tr(W S W H): the part of the term's expected cost the fit absorbs.
    sums->expected[t] += WS.trace() - (WS * WH).trace();
    sums->residuals[t] += d;
  }
}

}  // namespace

NoiseCalibrationResult calibrateNoise(const std::vector<SmoothingScan>& scans,
                                      const std::vector<SmoothingLandmark>& landmarks,
                                      const RangeBearingModel& model,
                                      const NoiseCalibrationParams& params) {
  NoiseCalibrationResult result;
  std::vector<Split> odometry(scans.size());
  std::vector<std::vector<Split>> observations(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    odometry[i] = odometrySplit(scans[i]);
    for (const SmoothingObservation& o : scans[i].observations)
      observations[i].push_back(observationSplit(o, params));
  }

  std::array<double, kNoiseTerms> theta;
  theta.fill(1.0);
  std::vector<SmoothingScan> current = scans;
  std::vector<SmoothingLandmark> start = landmarks;
  SmootherParams smoother;
  smoother.landmark_covariances = 0;
  smoother.residuals = true;
  for (int it = 0; it < params.max_iterations; ++it) {
    // The run with the current weights, from the last solution (warm start).
    for (std::size_t i = 0; i < scans.size(); ++i) {
      current[i].motion_covariance = odometry[i].covariance(theta);
      for (std::size_t j = 0; j < scans[i].observations.size(); ++j)
        current[i].observations[j].R = observations[i][j].covariance(theta).topLeftCorner<2, 2>();
    }
    SmoothingResult r = smoothRun(current, start, model, smoother);
    if (!r.ok) {
      result.error = r.error;
      return result;
    }
    TermSums sums;
    for (const SmoothingResidual& res : r.residuals) {
      const Split& split =
          res.observation < 0 ? odometry[res.scan] : observations[res.scan][res.observation];
      accumulate(split, res, theta, &sums);
    }
    const double cost_per_dof =
        r.degrees_of_freedom > 0 ? r.final_cost / static_cast<double>(r.degrees_of_freedom) : 0.0;
    if (it == 0) {
      result.cost_per_dof_before = cost_per_dof;
      result.degrees_of_freedom = r.degrees_of_freedom;
    }
    result.cost_per_dof_after = cost_per_dof;
    bool done = true;
    for (int t = 0; t < kNoiseTerms; ++t) {
      NoiseTermEstimate& e = result.terms[t];
      if (sums.expected[t] <= 0.0 || e.undetermined) continue;
      const double ratio = sums.cost[t] / sums.expected[t];
      if (it == 0) {
        e.residuals = sums.residuals[t];
        e.ratio_before = ratio;
        e.effective_dof = sums.expected[t];
        e.dof_share = sums.expected[t] / static_cast<double>(sums.residuals[t]);
      }
      if (sums.expected[t] < params.min_dof && ratio < 1.0) {
        // Little is left of it and it shrinks: a weakly determined variance heads for zero,
        // taking its last degrees of freedom with it. Back to the given value, for good. (One
        // whose cost is above its expectation grows, and gains dof as it does.)
        e.undetermined = true;
        e.calibrated = false;
        if (theta[t] != 1.0) done = false;  // smooth again without this term's change
        theta[t] = 1.0;
        continue;
      }
      e.ratio_after = ratio;
      e.calibrated = true;
      if (std::abs(ratio - 1.0) > params.tolerance) done = false;
    }
    result.iterations = it + 1;
    result.smoothing = std::move(r);
    if (done) {
      result.converged = true;
      break;
    }
    for (int t = 0; t < kNoiseTerms; ++t)
      if (result.terms[t].calibrated) theta[t] *= result.terms[t].ratio_after;
    for (std::size_t i = 0; i < scans.size(); ++i) current[i].pose = result.smoothing.poses[i];
    start = result.smoothing.landmarks;
  }
  for (int t = 0; t < kNoiseTerms; ++t) {
    result.terms[t].variance_factor = theta[t];
    result.terms[t].factor = std::sqrt(theta[t]);
  }
  result.ok = true;
  return result;
}

}  // namespace ekf_slam
