// AssociationContext: per-scan cache of predicted measurements and the innovation algebra every
// associator shares (individual S_ij, M_ij, and the joint covariance through pose and map).
#include "ekf_slam/core/association/association_context.h"

#include "ekf_slam/core/association/data_association.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace ekf_slam {

const char* toString(Decision d) {
  switch (d) {
    case Decision::kPaired:
      return "paired";
    case Decision::kNew:
      return "new";
    case Decision::kTentative:
      return "tentative";
    case Decision::kRejected:
      return "rejected";
  }
  return "unknown";
}

AssociationContext::AssociationContext(const EkfSlam& ekf, const RangeBearingModel& model,
                                       const LandmarkIndex& index,
                                       const std::vector<Observation>& observations, double stamp,
                                       const ScanOcclusion* occlusion)
    : ekf_(ekf),
      model_(model),
      index_(index),
      obs_(observations),
      stamp_(stamp),
      occlusion_(occlusion) {
  predictions_.reserve(64);
}

std::vector<int> AssociationContext::landmarksNear(const Eigen::Vector2d& center,
                                                   double radius) const {
  std::vector<int> out;
  index_.query(ekf_, center, radius, &out);
  // State order, so that results (and JCBB's "first found") do not depend on hash order.
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<int> AssociationContext::candidateLandmarks(double margin) const {
  if (obs_.empty() || ekf_.numLandmarks() == 0) return {};
  double r_max = 0.0;
  for (const Observation& o : obs_) r_max = std::max(r_max, RangeBearingModel::range(o.z, o.kind));
  // Any landmark within `margin` of some observed point lies within r_max + margin of the sensor.
  return landmarksNear(sensorPose().head<2>(), r_max + margin);
}

const AssociationContext::Prediction& AssociationContext::prediction(int landmark,
                                                                     MeasurementKind kind) const {
  auto [it, inserted] = predictions_.try_emplace(2 * landmark + static_cast<int>(kind));
  Prediction& p = it->second;
  if (inserted) {
    p.z_hat = model_.predict(ekf_.pose(), ekf_.landmark(landmark), kind, &p.H_pose, &p.H_landmark);
    Eigen::Vector2d mean;
    if (ekf_.secondOrderTerms(landmark, model_, kind, &mean, &p.extra)) p.z_hat += mean;
  }
  return p;
}

Eigen::Matrix2d AssociationContext::predictedCovariance(int landmark) const {
  const Prediction& p = prediction(landmark, MeasurementKind::kRangeBearing);
  const auto P = ekf_.storedCovariance();
  const int r = ekf_.stateRow(landmark);
  const Eigen::Matrix2d cross = p.H_pose * P.block<3, 2>(0, r) * p.H_landmark.transpose();
  Eigen::Matrix2d S = p.H_pose * P.topLeftCorner<3, 3>() * p.H_pose.transpose() + cross +
                      cross.transpose() +
                      p.H_landmark * P.block<2, 2>(r, r) * p.H_landmark.transpose() + p.extra;
  S(0, 1) = S(1, 0) = 0.5 * (S(0, 1) + S(1, 0));
  return S;
}

AssociationContext::Individual AssociationContext::individual(int obs, int landmark) const {
  ++evaluations_;
  const Observation& o = obs_[obs];
  const Prediction& p = prediction(landmark, o.kind);
  const auto P = ekf_.storedCovariance();  // a view, no copy; the blocks read here are current
  const int r = ekf_.stateRow(landmark);

  // S = H P H^T + R with H = [H_pose 0 .. H_landmark .. 0]: only the pose, landmark and
  // pose-landmark blocks of P take part.
  const Matrix23d HpPvv = p.H_pose * P.topLeftCorner<3, 3>();
  const Eigen::Matrix2d cross = p.H_pose * P.block<3, 2>(0, r) * p.H_landmark.transpose();
  Individual ind;
  ind.S = HpPvv * p.H_pose.transpose() + cross + cross.transpose() +
          p.H_landmark * P.block<2, 2>(r, r) * p.H_landmark.transpose() + o.R + p.extra;
  ind.S(0, 1) = ind.S(1, 0) = 0.5 * (ind.S(0, 1) + ind.S(1, 0));
  ind.v = RangeBearingModel::innovation(o.z, p.z_hat, o.kind);

  const double det = ind.S(0, 0) * ind.S(1, 1) - ind.S(0, 1) * ind.S(1, 0);
  if (!(det > 0.0) || !std::isfinite(det)) {
    // Degenerate geometry (e.g. landmark on the sensor): never compatible.
    ind.S_inv.setZero();
    ind.mahalanobis = std::numeric_limits<double>::infinity();
    ind.log_det_S = std::numeric_limits<double>::infinity();
    return ind;
  }
  ind.S_inv << ind.S(1, 1) / det, -ind.S(0, 1) / det, -ind.S(1, 0) / det, ind.S(0, 0) / det;
  ind.mahalanobis = ind.v.dot(ind.S_inv * ind.v);
  if (!std::isfinite(ind.mahalanobis)) ind.mahalanobis = std::numeric_limits<double>::infinity();
  ind.log_det_S = std::log(det);
  return ind;
}

Eigen::Vector2d AssociationContext::observedPosition(int obs) const {
  return model_.inverse(ekf_.pose(), obs_[obs].z, obs_[obs].kind);
}

Eigen::Vector2d AssociationContext::sightingPosition(const Eigen::Vector3d& xv,
                                                     const Eigen::Vector2d& z,
                                                     const Eigen::Matrix2d& R, MeasurementKind kind,
                                                     Matrix23d* G_pose,
                                                     Eigen::Matrix2d* cov) const {
  Eigen::Matrix2d G_obs;
  Eigen::Vector2d p = model_.inverse(xv, z, kind, G_pose, &G_obs);
  *cov = G_obs * R * G_obs.transpose();
  if (ekf_.secondOrderObservations() && kind == MeasurementKind::kRangeBearing) {
    Eigen::Vector2d mean;
    Eigen::Matrix2d extra;
    RangeBearingModel::polarSecondOrder(z(0), xv(2) + model_.sensorOffset()(2) + z(1), R, &mean,
                                        &extra);
    p += mean;
    *cov += extra;
  }
  return p;
}

Eigen::Matrix2d AssociationContext::innovationCovariance(int obs_a, int lm_a, int obs_b,
                                                         int lm_b) const {
  return innovationCovariance(obs_a, lm_a, obs_b, lm_b, shareOf(obs_b, lm_b));
}

void AssociationContext::innovationCovariances(const std::vector<std::pair<int, int>>& pairs,
                                               std::size_t count, int obs, int lm,
                                               Eigen::Ref<Eigen::MatrixXd> out) const {
  const PairShare b = shareOf(obs, lm);
  for (std::size_t a = 0; a < count; ++a) {
    out.middleRows<2>(2 * static_cast<Eigen::Index>(a)) =
        innovationCovariance(pairs[a].first, pairs[a].second, obs, lm, b);
  }
}

AssociationContext::PairShare AssociationContext::shareOf(int obs, int lm) const {
  const Prediction& b = prediction(lm, obs_[obs].kind);
  const auto P = ekf_.storedCovariance();  // a view, no copy; the blocks read here are current
  const int rb = ekf_.stateRow(lm);
  return {&b, rb,
          P.topLeftCorner<3, 3>() * b.H_pose.transpose() +
              P.block<3, 2>(0, rb) * b.H_landmark.transpose()};
}

Eigen::Matrix2d AssociationContext::innovationCovariance(int obs_a, int lm_a, int obs_b, int lm_b,
                                                         const PairShare& share) const {
  const Prediction& a = prediction(lm_a, obs_[obs_a].kind);
  const Prediction& b = *share.pred;
  const auto P = ekf_.storedCovariance();
  const int ra = ekf_.stateRow(lm_a);
  // cov(v_a, v_b) = H_a P H_b^T (+ R when both pairs use the same observation); the pose block
  // is what correlates pairs on different landmarks even when the map blocks are independent.
  const Eigen::Matrix<double, 2, 2> PmHb =
      P.block<2, 3>(ra, 0) * b.H_pose.transpose() +
      ekf_.blockCovariance(ra, share.row) * b.H_landmark.transpose();
  Eigen::Matrix2d C = a.H_pose * share.PvHb + a.H_landmark * PmHb;
  if (obs_a == obs_b) C += obs_[obs_a].R;
  // The second-order terms are the landmark's prediction's: shared by two pairs on it.
  if (lm_a == lm_b && obs_[obs_a].kind == obs_[obs_b].kind) C += a.extra;
  return C;
}

void AssociationContext::jointInnovation(const std::vector<std::pair<int, int>>& pairs,
                                         Eigen::VectorXd* v, Eigen::MatrixXd* S) const {
  const int k = static_cast<int>(pairs.size());
  v->resize(2 * k);
  S->resize(2 * k, 2 * k);
  for (int a = 0; a < k; ++a) {
    const auto& pa = pairs[a];
    const Observation& o = obs_[pa.first];
    v->segment<2>(2 * a) =
        RangeBearingModel::innovation(o.z, prediction(pa.second, o.kind).z_hat, o.kind);
    for (int b = a; b < k; ++b) {
      const auto& pb = pairs[b];
      const Eigen::Matrix2d C = innovationCovariance(pa.first, pa.second, pb.first, pb.second);
      S->block<2, 2>(2 * a, 2 * b) = C;
      if (b != a) S->block<2, 2>(2 * b, 2 * a) = C.transpose();
    }
  }
  *S = 0.5 * (*S + S->transpose()).eval();
}

double AssociationContext::jointMahalanobis(const std::vector<std::pair<int, int>>& pairs) const {
  if (pairs.empty()) return 0.0;
  Eigen::VectorXd v;
  Eigen::MatrixXd S;
  jointInnovation(pairs, &v, &S);
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const double d2 = v.dot(llt.solve(v));
  return std::isfinite(d2) ? d2 : std::numeric_limits<double>::infinity();
}

}  // namespace ekf_slam
