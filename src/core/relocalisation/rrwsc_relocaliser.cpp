// RRW&SC relocaliser: graph matching, two-point pose hypotheses from the best correspondences,
// verification, refinement and the ambiguity test; see the header.
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

#include <Eigen/LU>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/decompositions.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

void RRWSCRelocaliser::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  p_.matching.read(reader, 0.0);
  p_.min_inliers = reader.integer("min_inliers", 5, 2, 1000000);
  p_.inlier_probability = reader.probability("inlier_probability", 0.999);
  gate_ = chi2Quantile(p_.inlier_probability, 2);
  p_.hypothesis_sigma = reader.nonNegative("hypothesis_sigma", 1.0);
  p_.seed_candidates = reader.integer("seed_candidates", 24, 2, 100000);
  p_.ambiguity_ratio = reader.inRange("ambiguity_ratio", 0.8, 0.0, 1.0);
  p_.distinct_distance = reader.positive("distinct_distance", 2.0);
  p_.distinct_angle = reader.positive("distinct_angle", 0.1);
  p_.search_margin = reader.nonNegative("search_margin", 10.0);
}

void RRWSCRelocaliser::setMap(const std::vector<MapLandmark>& map) { map_ = map; }

bool RRWSCRelocaliser::distinct(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  return (a.head<2>() - b.head<2>()).norm() > p_.distinct_distance ||
         std::abs(wrapAngle(a.z() - b.z())) > p_.distinct_angle;
}

void RRWSCRelocaliser::score(const Eigen::Vector3d& sensor, double extra_var, Hypothesis* h) const {
  const int m = static_cast<int>(input_.observed.size());
  const int n = static_cast<int>(input_.landmarks.size());
  const Eigen::Matrix2d rot = rotation2d(sensor.z());
  h->sensor = sensor;
  h->landmark.assign(m, -1);
  h->inliers = 0;
  h->cost = 0.0;
  std::vector<double> d2(m, 0.0);
  std::vector<int> owner(n, -1);  // one observation per landmark: the closest keeps it
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector2d w = rot * input_.observed[i] + sensor.head<2>();
    int best = -1;
    double best_sq = std::numeric_limits<double>::infinity();
    for (int j = 0; j < n; ++j) {
      const double sq = (w - input_.landmarks[j]).squaredNorm();
      if (sq < best_sq) {
        best_sq = sq;
        best = j;
      }
    }
    if (best < 0) continue;
    const Eigen::Matrix2d s = rot * input_.observed_cov[i] * rot.transpose() +
                              input_.landmark_cov[best] + extra_var * Eigen::Matrix2d::Identity();
    const Eigen::Vector2d e = w - input_.landmarks[best];
    const double mij = e.dot(s.inverse() * e);
    if (!(mij <= gate_)) continue;
    if (owner[best] >= 0) {
      if (d2[owner[best]] <= mij) continue;
      h->landmark[owner[best]] = -1;
    }
    owner[best] = i;
    d2[i] = mij;
    h->landmark[i] = best;
  }
  for (int i = 0; i < m; ++i) {
    if (h->landmark[i] < 0) continue;
    ++h->inliers;
    h->cost += d2[i];
  }
}

void RRWSCRelocaliser::information(const Hypothesis& h, const Eigen::Vector3d& sensor,
                                   Eigen::Matrix3d* info, Eigen::Vector3d* grad) const {
  // Residual e = R p + t - l, J = [I, dR/dtheta p]: info = sum J^T S^-1 J, grad = sum J^T S^-1 e.
  info->setZero();
  grad->setZero();
  const Eigen::Matrix2d rot = rotation2d(sensor.z());
  Eigen::Matrix2d drot;
  drot << -rot(1, 0), -rot(0, 0), rot(0, 0), -rot(1, 0);
  for (std::size_t i = 0; i < h.landmark.size(); ++i) {
    const int j = h.landmark[i];
    if (j < 0) continue;
    Eigen::Matrix<double, 2, 3> jac;
    jac.leftCols<2>().setIdentity();
    jac.col(2) = drot * input_.observed[i];
    const Eigen::Matrix2d s_inv =
        (rot * input_.observed_cov[i] * rot.transpose() + input_.landmark_cov[j]).inverse();
    const Eigen::Vector2d e = rot * input_.observed[i] + sensor.head<2>() - input_.landmarks[j];
    *info += jac.transpose() * s_inv * jac;
    *grad += jac.transpose() * s_inv * e;
  }
}

void RRWSCRelocaliser::refine(Hypothesis* h, Eigen::Matrix3d* cov) const {
  const int m = static_cast<int>(input_.observed.size());
  for (int round = 0; round < 4 && h->inliers >= 2; ++round) {
    // Closed-form weighted rigid fit (2D Procrustes), weights 1 / trace of the residual
    // covariance.
    double wsum = 0.0;
    Eigen::Vector2d pc = Eigen::Vector2d::Zero(), lc = Eigen::Vector2d::Zero();
    std::vector<double> w(m, 0.0);
    for (int i = 0; i < m; ++i) {
      const int j = h->landmark[i];
      if (j < 0) continue;
      w[i] = 1.0 / (input_.observed_cov[i].trace() + input_.landmark_cov[j].trace() + 1e-9);
      wsum += w[i];
      pc += w[i] * input_.observed[i];
      lc += w[i] * input_.landmarks[j];
    }
    pc /= wsum;
    lc /= wsum;
    Eigen::Matrix2d cross = Eigen::Matrix2d::Zero();
    for (int i = 0; i < m; ++i) {
      const int j = h->landmark[i];
      if (j >= 0)
        cross += w[i] * (input_.observed[i] - pc) * (input_.landmarks[j] - lc).transpose();
    }
    const double theta = std::atan2(cross(0, 1) - cross(1, 0), cross(0, 0) + cross(1, 1));
    const Eigen::Vector2d t = lc - rotation2d(theta) * pc;
    // Then Gauss-Newton on the full residual covariances (bearing noise makes far points'
    // residuals long and thin, which the scalar weights above ignore).
    Eigen::Vector3d pose(t.x(), t.y(), theta);
    Eigen::Matrix3d info;
    for (int step = 0; step < 2; ++step) {
      Eigen::Vector3d grad;
      information(*h, pose, &info, &grad);
      const std::optional<Eigen::Vector3d> delta = fullPivSolve(info, grad);
      if (!delta) break;
      pose -= *delta;
    }
    pose.z() = wrapAngle(pose.z());
    score(pose, 0.0, h);
  }
  Eigen::Matrix3d info;
  Eigen::Vector3d grad;
  information(*h, h->sensor, &info, &grad);
  const std::optional<Eigen::Matrix3d> inverse = fullPivInverse(info);
  *cov = inverse ? *inverse : Eigen::Matrix3d(Eigen::Matrix3d::Identity() * 1e6);
}

RelocalisationResult RRWSCRelocaliser::relocalise(const std::vector<Observation>& observations,
                                                  const Eigen::Vector3d& sensor_offset,
                                                  const PosePrior* prior) {
  RelocalisationResult res;
  const int m = static_cast<int>(observations.size());
  res.landmark.assign(m, kNoLandmark);
  if (m < p_.min_inliers) {
    res.reason = "too few observations";
    return res;
  }
  // The map graph: every landmark, or with a prior those within reach of its sensor position.
  local_.clear();
  Eigen::Vector3d prior_sensor = Eigen::Vector3d::Zero();
  if (prior != nullptr) {
    prior_sensor = composePose(prior->mean, sensor_offset);
    double max_range = 0.0;
    for (const Observation& o : observations) max_range = std::max(max_range, o.z.x());
    const double sigma = std::sqrt(
        std::max(0.0, symmetricEigen(prior->covariance.topLeftCorner<2, 2>()).values.maxCoeff()));
    const double reach = max_range + 3.0 * sigma + p_.search_margin;
    for (int k = 0; k < static_cast<int>(map_.size()); ++k) {
      if ((map_[k].position - prior_sensor.head<2>()).norm() <= reach) local_.push_back(k);
    }
  } else {
    local_.resize(map_.size());
    std::iota(local_.begin(), local_.end(), 0);
  }
  const int n = static_cast<int>(local_.size());
  if (n < p_.min_inliers) {
    res.reason = "too few landmarks";
    return res;
  }
  setObservedPoints(observations, &input_);
  input_.landmarks.resize(n);
  input_.landmark_cov.resize(n);
  for (int j = 0; j < n; ++j) {
    input_.landmarks[j] = map_[local_[j]].position;
    input_.landmark_cov[j] = map_[local_[j]].covariance;
  }
  input_.mahalanobis.resize(0, 0);
  if (prior != nullptr && p_.matching.position_weight > 0.0) {
    // M_ij of the observation's map position under the prior (pose covariance through
    // J = [I, dR/dtheta p], the sensor offset's lever arm neglected).
    const Eigen::Matrix2d rot = rotation2d(prior_sensor.z());
    Eigen::Matrix2d drot;
    drot << -rot(1, 0), -rot(0, 0), rot(0, 0), -rot(1, 0);
    input_.mahalanobis.resize(m, n);
    for (int i = 0; i < m; ++i) {
      Eigen::Matrix<double, 2, 3> jac;
      jac.leftCols<2>().setIdentity();
      jac.col(2) = drot * input_.observed[i];
      const Eigen::Vector2d w = rot * input_.observed[i] + prior_sensor.head<2>();
      const Eigen::Matrix2d base = rot * input_.observed_cov[i] * rot.transpose() +
                                   jac * prior->covariance * jac.transpose();
      for (int j = 0; j < n; ++j) {
        const Eigen::Vector2d e = w - input_.landmarks[j];
        input_.mahalanobis(i, j) = e.dot((base + input_.landmark_cov[j]).inverse() * e);
      }
    }
  }
  matcher_.match(input_, p_.matching, &match_);
  res.nodes = static_cast<std::uint64_t>(matcher_.stats().iterations);

  // Hypotheses: the matching itself, and every consistent pair of the best-scoring
  // correspondences (a symmetric map puts both of its alternatives among them).
  std::vector<Hypothesis> hyps;
  {
    Hypothesis h;
    h.landmark = match_;
    h.inliers =
        static_cast<int>(std::count_if(match_.begin(), match_.end(), [](int j) { return j >= 0; }));
    Eigen::Matrix3d unused;
    refine(&h, &unused);
    hyps.push_back(h);
  }
  const MatchGraph& g = matcher_.graph();
  const Eigen::VectorXd& x = matcher_.scores();
  std::vector<int> seeds(g.size());
  std::iota(seeds.begin(), seeds.end(), 0);
  const int k = std::min<int>(p_.seed_candidates, g.size());
  std::partial_sort(seeds.begin(), seeds.begin() + k, seeds.end(),
                    [&](int a, int b) { return x[a] > x[b] || (x[a] == x[b] && a < b); });
  const double extra = p_.hypothesis_sigma * p_.hypothesis_sigma;
  for (int s1 = 0; s1 < k; ++s1) {
    for (int s2 = s1 + 1; s2 < k; ++s2) {
      const int c1 = seeds[s1], c2 = seeds[s2];
      if (g.row[c1] == g.row[c2] || g.col[c1] == g.col[c2]) continue;
      const Eigen::Vector2d dp = input_.observed[g.row[c2]] - input_.observed[g.row[c1]];
      const Eigen::Vector2d dl = input_.landmarks[g.col[c2]] - input_.landmarks[g.col[c1]];
      const double var =
          input_.observed_cov[g.row[c1]].trace() + input_.observed_cov[g.row[c2]].trace() +
          input_.landmark_cov[g.col[c1]].trace() + input_.landmark_cov[g.col[c2]].trace() + extra;
      if (dp.norm() < 1.0 || std::abs(dp.norm() - dl.norm()) > 3.0 * std::sqrt(var)) continue;
      const double theta = std::atan2(dl.y(), dl.x()) - std::atan2(dp.y(), dp.x());
      const Eigen::Vector2d t =
          0.5 * (input_.landmarks[g.col[c1]] + input_.landmarks[g.col[c2]]) -
          rotation2d(theta) * 0.5 * (input_.observed[g.row[c1]] + input_.observed[g.row[c2]]);
      Hypothesis h;
      score({t.x(), t.y(), wrapAngle(theta)}, extra, &h);
      hyps.push_back(std::move(h));
      ++res.nodes;
    }
  }
  std::sort(hyps.begin(), hyps.end(), [](const Hypothesis& a, const Hypothesis& b) {
    return a.inliers > b.inliers || (a.inliers == b.inliers && a.cost < b.cost);
  });
  Hypothesis best = hyps.front();
  Eigen::Matrix3d cov;
  refine(&best, &cov);
  if (best.inliers < p_.min_inliers) {
    res.reason = "best pose explains " + std::to_string(best.inliers) + " observations";
    return res;
  }
  // The runner-up: the best hypothesis that stays distinct from the best after refinement.
  int runner_inliers = 0;
  int tried = 0;
  for (std::size_t h = 1; h < hyps.size() && tried < 8; ++h) {
    if (!distinct(hyps[h].sensor, best.sensor)) continue;
    if (hyps[h].inliers <= runner_inliers) break;  // sorted: none better follows
    ++tried;
    Hypothesis alt = hyps[h];
    Eigen::Matrix3d unused;
    refine(&alt, &unused);
    if (distinct(alt.sensor, best.sensor)) runner_inliers = std::max(runner_inliers, alt.inliers);
  }
  res.hypothesis_size = best.inliers;
  res.joint_mahalanobis = best.cost;
  if (runner_inliers >= p_.ambiguity_ratio * best.inliers) {
    res.status = RelocalisationStatus::kAmbiguous;
    res.reason = "a distinct pose explains " + std::to_string(runner_inliers) + " of the best's " +
                 std::to_string(best.inliers) + " observations";
    return res;
  }
  // Vehicle pose from the sensor pose: v = s (+) offset^-1.
  const double yaw = wrapAngle(best.sensor.z() - sensor_offset.z());
  const Eigen::Matrix2d rv = rotation2d(yaw);
  res.pose << best.sensor.head<2>() - rv * sensor_offset.head<2>(), yaw;
  Eigen::Matrix3d jac = Eigen::Matrix3d::Identity();
  Eigen::Matrix2d drv;
  drv << -rv(1, 0), -rv(0, 0), rv(0, 0), -rv(1, 0);
  jac.block<2, 1>(0, 2) = -drv * sensor_offset.head<2>();
  res.covariance = jac * cov * jac.transpose();
  for (int i = 0; i < m; ++i) {
    if (best.landmark[i] >= 0) res.landmark[i] = map_[local_[best.landmark[i]]].id;
  }
  res.status = RelocalisationStatus::kFound;
  return res;
}

}  // namespace ekf_slam
