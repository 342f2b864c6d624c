#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"

#include <algorithm>
#include <cmath>

namespace ekf_slam {

Eigen::Matrix2d RigidTransform2::rotation() const {
  const double c = std::cos(yaw), s = std::sin(yaw);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

RigidTransform2 alignRigid2D(const std::vector<Eigen::Vector2d>& from,
                             const std::vector<Eigen::Vector2d>& to) {
  RigidTransform2 t;
  const std::size_t n = std::min(from.size(), to.size());
  if (n == 0) return t;
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    ca += from[i];
    cb += to[i];
  }
  ca /= static_cast<double>(n);
  cb /= static_cast<double>(n);
  // In 2D the SVD of the cross-covariance reduces to one angle: the rotation maximising
  // sum b_i . R a_i is atan2(sum a x b, sum a . b) over the centred points.
  double dot = 0.0, cross = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = from[i] - ca, b = to[i] - cb;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  t.yaw = (dot == 0.0 && cross == 0.0) ? 0.0 : std::atan2(cross, dot);
  t.translation = cb - t.rotation() * ca;
  return t;
}

std::optional<Eigen::Vector2d> interpolatePosition(const std::vector<StampedPoint>& trajectory,
                                                   double stamp, double max_gap) {
  if (trajectory.empty() || !std::isfinite(stamp)) return std::nullopt;
  if (stamp < trajectory.front().stamp || stamp > trajectory.back().stamp) return std::nullopt;
  // First sample with a stamp >= the query.
  const auto hi = std::lower_bound(trajectory.begin(), trajectory.end(), stamp,
                                   [](const StampedPoint& p, double s) { return p.stamp < s; });
  if (hi->stamp == stamp) return hi->position;
  const auto lo = hi - 1;  // exists: stamp > front().stamp
  const double dt = hi->stamp - lo->stamp;
  if (!(dt > 0.0) || dt > max_gap) return std::nullopt;
  const double f = (stamp - lo->stamp) / dt;
  return lo->position + f * (hi->position - lo->position);
}

TrajectoryError compareTrajectories(std::vector<StampedPoint> estimate,
                                    const std::vector<StampedPoint>& reference,
                                    const TrajectoryErrorOptions& options) {
  const auto bad = [](const StampedPoint& p) {
    return !std::isfinite(p.stamp) || !p.position.allFinite();
  };
  estimate.erase(std::remove_if(estimate.begin(), estimate.end(), bad), estimate.end());
  std::stable_sort(estimate.begin(), estimate.end(),
                   [](const StampedPoint& a, const StampedPoint& b) { return a.stamp < b.stamp; });
  // Duplicate stamps would make a zero-length interval: keep the last estimate of a stamp.
  std::vector<StampedPoint> unique;
  unique.reserve(estimate.size());
  for (const auto& p : estimate) {
    if (!unique.empty() && unique.back().stamp == p.stamp) {
      unique.back() = p;
    } else {
      unique.push_back(p);
    }
  }

  TrajectoryError out;
  std::vector<Eigen::Vector2d> est, ref;
  est.reserve(reference.size());
  ref.reserve(reference.size());
  for (const auto& r : reference) {
    const auto e =
        bad(r) ? std::nullopt : interpolatePosition(unique, r.stamp, options.max_interpolation_gap);
    if (!e) {
      ++out.skipped;
      continue;
    }
    est.push_back(*e);
    ref.push_back(r.position);
  }
  out.points = est.size();
  if (est.empty()) return out;

  out.alignment = alignRigid2D(est, ref);
  const Eigen::Matrix2d rot = out.alignment.rotation();
  double sum_aligned = 0.0, sum_raw = 0.0;
  std::vector<double> errors(est.size());
  for (std::size_t i = 0; i < est.size(); ++i) {
    const double ea = (rot * est[i] + out.alignment.translation - ref[i]).squaredNorm();
    sum_aligned += ea;
    sum_raw += (est[i] - ref[i]).squaredNorm();
    errors[i] = std::sqrt(ea);
  }
  const double n = static_cast<double>(est.size());
  out.rmse_aligned = std::sqrt(sum_aligned / n);
  out.rmse_unaligned = std::sqrt(sum_raw / n);
  std::sort(errors.begin(), errors.end());
  out.max_aligned = errors.back();
  // Nearest-rank percentiles.
  const auto rank = [&](double q) {
    return errors[std::min(errors.size() - 1, static_cast<std::size_t>(std::ceil(q * n)) - 1)];
  };
  out.median_aligned = rank(0.5);
  out.p95_aligned = rank(0.95);
  return out;
}

namespace {

// Path length travelled from the first odometry stamp up to each GPS stamp (sorted), from the
// held speeds.
std::vector<double> pathLengthAt(const std::vector<StampedPoint>& gps,
                                 const std::vector<StampedSpeed>& odometry) {
  std::vector<double> out(gps.size(), 0.0);
  if (odometry.empty()) return out;
  std::size_t k = 0;     // odometry sample in force
  double travelled = 0;  // up to odometry[k].stamp
  for (std::size_t i = 0; i < gps.size(); ++i) {
    const double t = gps[i].stamp;
    while (k + 1 < odometry.size() && odometry[k + 1].stamp <= t) {
      travelled += std::abs(odometry[k].speed) * (odometry[k + 1].stamp - odometry[k].stamp);
      ++k;
    }
    const double dt = std::max(0.0, t - odometry[k].stamp);
    // Beyond the last sample its speed is held; before the first the vehicle is taken as moving
    // at the first speed (both only matter at the very ends of a bag).
    const double before = t < odometry.front().stamp
                              ? std::abs(odometry.front().speed) * (odometry.front().stamp - t)
                              : 0.0;
    out[i] = travelled + std::abs(odometry[k].speed) * dt - before;
  }
  return out;
}

}  // namespace

std::vector<bool> faultyGpsFixes(const std::vector<StampedPoint>& gps,
                                 const std::vector<StampedSpeed>& odometry,
                                 const GpsFaultOptions& options) {
  std::vector<bool> faulty(gps.size(), false);
  if (gps.size() < 3) return faulty;
  const std::vector<double> path = pathLengthAt(gps, odometry);
  const auto consistent = [&](std::size_t a, std::size_t b) {
    const double d = std::abs(path[b] - path[a]);
    return (gps[b].position - gps[a].position).norm() <=
           (1.0 + options.path_tolerance) * d + options.distance_tolerance;
  };
  std::size_t good = 0;
  for (std::size_t i = 1; i < gps.size(); ++i) {
    if (consistent(good, i)) {
      good = i;
      continue;
    }
    // A jump: faulty if the track comes back within max_run fixes.
    std::size_t back = 0;
    for (std::size_t j = i + 1; j < gps.size() && j < i + options.max_run + 1; ++j) {
      if (consistent(good, j)) {
        back = j;
        break;
      }
    }
    // No way back, or the track after the return agrees with the jumped fix (the tolerance
    // merely caught up with a lasting shift): a lasting jump, not judged.
    if (back == 0 || consistent(i, back)) {
      good = i;
      continue;
    }
    for (std::size_t j = i; j < back; ++j) faulty[j] = true;
    good = back;
    i = back;
  }
  return faulty;
}

}  // namespace ekf_slam
