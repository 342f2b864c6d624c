// Geometry shared by FGCBB and GCBB. See geometric_constraints.h.
#include "ekf_slam/core/relocalisation/geometric_constraints.h"

#include <algorithm>
#include <cmath>

#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/decompositions.h"

namespace ekf_slam {

namespace {

bool positiveDefinite(const Eigen::Matrix2d& C) {
  return C.allFinite() && C(0, 0) > 0.0 && C(1, 1) > 0.0 && C.determinant() > 0.0;
}

// Variance of |a - b| through its gradient u = (a - b) / |a - b|; isotropic when a == b.
double distanceVariance(const Eigen::Vector2d& d, const Eigen::Matrix2d& cov) {
  const double n = d.norm();
  if (n < 1e-9) return 0.5 * cov.trace();
  const Eigen::Vector2d u = d / n;
  return u.dot(cov * u);
}

}  // namespace

std::vector<ObservedPoint> observedPoints(const std::vector<Observation>& observations,
                                          const Eigen::Vector3d& sensor_offset, double max_range) {
  std::vector<ObservedPoint> out;
  out.reserve(observations.size());
  const Eigen::Matrix2d Rs = rotation2d(sensor_offset.z());
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const Observation& o = observations[i];
    const double r = RangeBearingModel::range(o.z, o.kind);
    if (!o.z.allFinite() || !(r > 0.0) || r > max_range || !positiveDefinite(o.R)) continue;
    if (std::isinf(o.descriptor)) continue;
    Eigen::Matrix2d J;  // d(point in the sensor frame) / dz
    const Eigen::Vector2d ps = RangeBearingModel::sensorPoint(o.z, o.kind, &J);
    const Eigen::Matrix2d G = Rs * J;
    ObservedPoint p;
    p.input = static_cast<int>(i);
    p.p = sensor_offset.head<2>() + Rs * ps;
    p.cov = G * o.R * G.transpose();
    p.range = r;
    p.descriptor = o.descriptor;
    out.push_back(p);
  }
  return out;
}

bool unaryCompatible(double d_obs, double d_map, double variance, double gate) {
  if (std::isnan(d_obs) || std::isnan(d_map)) return true;
  const double e = d_obs - d_map;
  return e * e <= gate * variance;
}

double binaryStatistic(const Eigen::Vector2d& a, const Eigen::Matrix2d& cov_a,
                       const Eigen::Vector2d& b, const Eigen::Matrix2d& cov_b,
                       const Eigen::Vector2d& ma, const Eigen::Matrix2d& cov_ma,
                       const Eigen::Vector2d& mb, const Eigen::Matrix2d& cov_mb) {
  const Eigen::Vector2d d_obs = a - b, d_map = ma - mb;
  const double e = d_obs.norm() - d_map.norm();
  const double var =
      distanceVariance(d_obs, cov_a + cov_b) + distanceVariance(d_map, cov_ma + cov_mb);
  return var > 0.0 ? e * e / var : (e == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
}

// --- map table -----------------------------------------------------------------------------------

namespace {
// Cell (ix, iy) -> one key: ix in the high half, iy's low 32 bits in the low half. Shifted as
// unsigned: a left shift of a negative signed value is undefined (UBSan found it).
std::int64_t cellKey(std::int64_t ix, std::int64_t iy) {
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}
}  // namespace

MapPairTable::CellKey MapPairTable::keyOf(const Eigen::Vector2d& p) const {
  return cellKey(static_cast<std::int64_t>(std::floor(p.x() / radius_)),
                 static_cast<std::int64_t>(std::floor(p.y() / radius_)));
}

void MapPairTable::build(const std::vector<MapLandmark>& map, double radius) {
  radius_ = radius;
  landmarks_.clear();
  cells_.clear();
  max_variance_ = 0.0;
  for (const MapLandmark& l : map) {
    if (!l.position.allFinite() || !l.covariance.allFinite()) continue;
    landmarks_.push_back(l);
    max_variance_ = std::max(max_variance_, l.covariance.trace());
  }
  for (std::size_t j = 0; j < landmarks_.size(); ++j)
    cells_[keyOf(landmarks_[j].position)].push_back(static_cast<int>(j));
  neighbours_.assign(landmarks_.size(), {});
  std::vector<int> near;
  for (std::size_t j = 0; j < landmarks_.size(); ++j) {
    near.clear();
    query(landmarks_[j].position, radius_, &near);
    const Eigen::Vector2d mj = landmarks_[j].position;
    std::vector<int>& out = neighbours_[j];
    for (const int l : near) {
      if (l != static_cast<int>(j) && local(static_cast<int>(j), l)) out.push_back(l);
    }
    std::sort(out.begin(), out.end(), [&](int a, int b) {
      return (landmarks_[a].position - mj).squaredNorm() <
             (landmarks_[b].position - mj).squaredNorm();
    });
  }
}

bool MapPairTable::local(int i, int j) const {
  return (landmarks_[i].position - landmarks_[j].position).squaredNorm() < radius_ * radius_;
}

void MapPairTable::query(const Eigen::Vector2d& center, double r, std::vector<int>* out) const {
  if (landmarks_.empty() || !(r >= 0.0) || !center.allFinite()) return;
  const double cell = radius_;
  const auto x0 = static_cast<std::int64_t>(std::floor((center.x() - r) / cell));
  const auto x1 = static_cast<std::int64_t>(std::floor((center.x() + r) / cell));
  const auto y0 = static_cast<std::int64_t>(std::floor((center.y() - r) / cell));
  const auto y1 = static_cast<std::int64_t>(std::floor((center.y() + r) / cell));
  // A huge radius (a loose prior) touches more cells than there are landmarks: scan them all.
  if (static_cast<double>(x1 - x0 + 1) * static_cast<double>(y1 - y0 + 1) >
      static_cast<double>(landmarks_.size())) {
    for (std::size_t j = 0; j < landmarks_.size(); ++j) {
      if ((landmarks_[j].position - center).squaredNorm() <= r * r)
        out->push_back(static_cast<int>(j));
    }
    return;
  }
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      const auto it = cells_.find(cellKey(ix, iy));
      if (it == cells_.end()) continue;
      for (const int j : it->second) {
        if ((landmarks_[j].position - center).squaredNorm() <= r * r) out->push_back(j);
      }
    }
  }
}

// --- pose ----------------------------------------------------------------------------------------

PoseFit fitPose(const std::vector<PointPairing>& pairings, int iterations) {
  PoseFit fit;
  const std::size_t k = pairings.size();
  if (k < 2) return fit;
  // Closed form: centroids, then the rotation of the centred points (Procrustes in 2D).
  Eigen::Vector2d cp = Eigen::Vector2d::Zero(), cm = Eigen::Vector2d::Zero();
  for (const PointPairing& q : pairings) {
    cp += q.obs->p;
    cm += q.landmark->position;
  }
  cp /= static_cast<double>(k);
  cm /= static_cast<double>(k);
  double s_cos = 0.0, s_sin = 0.0;
  for (const PointPairing& q : pairings) {
    const Eigen::Vector2d a = q.obs->p - cp, b = q.landmark->position - cm;
    s_cos += a.dot(b);
    s_sin += a.x() * b.y() - a.y() * b.x();
  }
  double phi = std::atan2(s_sin, s_cos);
  Eigen::Vector2d t = cm - rotation2d(phi) * cp;

  // Weighted Gauss-Newton on r_i = m_j - (R(phi) p_i + t), W_i = (C_j + R cov_i R^T)^-1.
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (int it = 0; it <= iterations; ++it) {
    const Eigen::Matrix2d R = rotation2d(phi);
    Eigen::Matrix2d dR;  // dR/dphi
    dR << -std::sin(phi), -std::cos(phi), std::cos(phi), -std::sin(phi);
    H.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    double d2 = 0.0;
    for (const PointPairing& q : pairings) {
      const Eigen::Vector2d r = q.landmark->position - (R * q.obs->p + t);
      const Eigen::Matrix2d S = q.landmark->covariance + R * q.obs->cov * R.transpose();
      const Eigen::LLT<Eigen::Matrix2d> llt(S);
      if (llt.info() != Eigen::Success) return fit;
      const Eigen::Matrix2d W = llt.solve(Eigen::Matrix2d::Identity());
      Eigen::Matrix<double, 2, 3> J;  // dr / d(x, y, phi)
      J << -Eigen::Matrix2d::Identity(), -dR * q.obs->p;
      H += J.transpose() * W * J;
      g += J.transpose() * W * r;
      d2 += r.dot(W * r);
    }
    fit.d2 = d2;
    if (it == iterations) break;
    const Eigen::Vector3d step = -ldltSolve(H, g);
    if (!step.allFinite()) return fit;
    t += step.head<2>();
    phi = wrapAngle(phi + step.z());
    if (step.norm() < 1e-10) iterations = it + 1;  // converged: one more pass for H and d2
  }
  const std::optional<Eigen::Matrix3d> inverse = fullPivInverse(H);
  if (!inverse) return fit;
  fit.covariance = *inverse;
  fit.covariance = 0.5 * (fit.covariance + fit.covariance.transpose()).eval();
  fit.pose = Eigen::Vector3d(t.x(), t.y(), phi);
  fit.ok = fit.pose.allFinite() && fit.covariance.allFinite() && std::isfinite(fit.d2);
  return fit;
}

Eigen::Matrix2d capCovariance(const Eigen::Matrix2d& cov, double sigma) {
  if (sigma <= 0.0 || !cov.allFinite()) return cov;
  const SymmetricEigen2 eig = symmetricEigen(cov);
  const Eigen::Vector2d d = eig.values.cwiseMin(sigma * sigma);
  return eig.vectors * d.asDiagonal() * eig.vectors.transpose();
}

}  // namespace ekf_slam
