// EKF-SLAM state and filter steps on a dense covariance.
#include "ekf_slam/core/ekf_slam.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "ekf_slam/core/angles.h"

namespace ekf_slam {

namespace {

// Copies the lower triangle onto the upper one: the rank update only writes the lower half, and
// this also makes P exactly symmetric. Tiled so that the strided reads stay in cache.
void mirrorLower(Eigen::MatrixXd* P) {
  constexpr Eigen::Index kTile = 32;
  const Eigen::Index n = P->rows();
  double* d = P->data();
  for (Eigen::Index jb = 0; jb < n; jb += kTile) {
    const Eigen::Index je = std::min(jb + kTile, n);
    for (Eigen::Index ib = 0; ib <= jb; ib += kTile) {
      for (Eigen::Index j = jb; j < je; ++j) {
        double* col = d + j * n;
        const Eigen::Index ie = std::min(ib + kTile, j);
        for (Eigen::Index i = ib; i < ie; ++i) col[i] = d[i * n + j];
      }
    }
  }
}

}  // namespace

EkfSlam::EkfSlam() { reset(); }

void EkfSlam::reset(const Eigen::Vector3d& pose, const Eigen::Matrix3d& pose_cov,
                    const CorrectionPrior& correction) {
  const int k = correction.dim;
  if (k < 0 || k > kMaxCorrectionStates || !correction.mean.allFinite() ||
      !correction.sigma.allFinite()) {
    throw std::invalid_argument("EkfSlam::reset: invalid correction prior (dim " +
                                std::to_string(k) + ")");
  }
  k_ = k;
  c_lower_ = correction.lower;
  c_upper_ = correction.upper;
  x_.resize(3 + k);
  x_.head<3>() = pose;
  x_(2) = wrapAngle(x_(2));
  x_.segment(3, k) = correction.mean.head(k);
  P_ = Eigen::MatrixXd::Zero(3 + k, 3 + k);
  P_.topLeftCorner<3, 3>() = 0.5 * (pose_cov + pose_cov.transpose());
  P_.block(3, 3, k, k) = correction.sigma.head(k).cwiseAbs2().asDiagonal();
  ids_.clear();
  index_of_.clear();
  next_id_ = 0;
}

Eigen::Vector2d EkfSlam::correction() const {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  c.head(k_) = x_.segment(3, k_);
  return c;
}

Eigen::Matrix2d EkfSlam::correctionCovariance() const {
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  C.topLeftCorner(k_, k_) = P_.block(3, 3, k_, k_);
  return C;
}

void EkfSlam::replacePose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& pose_cov) {
  x_.head<3>() = pose;
  x_(2) = wrapAngle(x_(2));
  P_.topLeftCorner<3, 3>() = 0.5 * (pose_cov + pose_cov.transpose());
  const Eigen::Index n = P_.rows() - 3;
  P_.topRightCorner(3, n).setZero();
  P_.bottomLeftCorner(n, 3).setZero();
}

int EkfSlam::indexOf(LandmarkId id) const {
  const auto it = index_of_.find(id);
  return it == index_of_.end() ? -1 : it->second;
}

bool EkfSlam::predict(const MotionStep& step) {
  if (!step.pose.allFinite() || !step.F.allFinite() || !step.Q.allFinite()) return false;
  if (step.corrections != k_) return false;
  if (k_ > 0) return predictAugmented(step);
  const Eigen::Matrix3d& F = step.F;
  x_.head<3>() = step.pose;
  x_(2) = wrapAngle(x_(2));

  const Eigen::Matrix3d Pvv = P_.topLeftCorner<3, 3>();
  Eigen::Matrix3d Pn = F * Pvv * F.transpose() + step.Q;
  P_.topLeftCorner<3, 3>() = 0.5 * (Pn + Pn.transpose());

  // Pose/map cross-covariance, one landmark at a time: fixed-size blocks, no temporaries.
  const Eigen::Index n = P_.rows();
  for (Eigen::Index r = 3; r < n; r += 2) {
    const Eigen::Matrix<double, 3, 2> c = F * P_.block<3, 2>(0, r);
    P_.block<3, 2>(0, r) = c;
    P_.block<2, 3>(r, 0) = c.transpose();
  }
  return true;
}

bool EkfSlam::predictAugmented(const MotionStep& step) {
  if (!step.Fc.allFinite() || !step.Qvc.allFinite() || !step.Qc.allFinite()) return false;
  // Vehicle block a = [pose, c] with transition A = [F Fc; 0 I]; only the pose rows change, so
  // the map part is B P_am with B = [F Fc] (3 x a): still O(n).
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3 + kMaxCorrectionStates,
                              3 + kMaxCorrectionStates>;
  const int a = 3 + k_;
  Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, 3 + kMaxCorrectionStates> B(3, a);
  B.leftCols<3>() = step.F;
  B.rightCols(k_) = step.Fc.leftCols(k_);
  Small A = Small::Identity(a, a);
  A.topRows<3>() = B;
  Small N = Small::Zero(a, a);
  N.topLeftCorner<3, 3>() = step.Q;
  N.topRightCorner(3, k_) = step.Qvc.leftCols(k_);
  N.bottomLeftCorner(k_, 3) = step.Qvc.leftCols(k_).transpose();
  N.bottomRightCorner(k_, k_) = step.Qc.topLeftCorner(k_, k_);
  const Small Paa = P_.topLeftCorner(a, a);
  Small Pn = A * Paa * A.transpose() + N;
  P_.topLeftCorner(a, a) = 0.5 * (Pn + Pn.transpose());

  x_.head<3>() = step.pose;
  x_(2) = wrapAngle(x_(2));
  const Eigen::Index n = P_.rows();
  for (Eigen::Index r = a; r < n; r += 2) {
    const Eigen::Matrix<double, 3, 2> c = B * P_.block(0, r, a, 2);
    P_.block<3, 2>(0, r) = c;
    P_.block<2, 3>(r, 0) = c.transpose();
  }
  return true;
}

bool EkfSlam::update(const std::vector<Pairing>& pairings, const RangeBearingModel& model,
                     double* nis) {
  const int m = static_cast<int>(pairings.size());
  if (m == 0) {
    if (nis) *nis = 0.0;
    return true;
  }
  const Eigen::Index n = x_.size();
  const int d = 2 * m;
  const Eigen::Vector3d xv = x_.head<3>();

  rows_.resize(m);
  hv_.resize(m);
  hm_.resize(m);
  v_.resize(d);
  for (int i = 0; i < m; ++i) {
    const Pairing& p = pairings[i];
    const int idx = indexOf(p.id);
    if (idx < 0 || !p.z.allFinite() || !p.R.allFinite()) return false;
    rows_[i] = stateRow(idx);
    const Eigen::Vector2d z_hat =
        model.predict(xv, x_.segment<2>(rows_[i]), p.kind, &hv_[i], &hm_[i]);
    if (!z_hat.allFinite() || !hv_[i].allFinite() || !hm_[i].allFinite()) return false;
    v_.segment<2>(2 * i) = RangeBearingModel::innovation(p.z, z_hat, p.kind);
  }

  // P H^T: each 2-row block of H has a pose part and one landmark part, so it costs O(n m).
  pht_.resize(n, d);
  for (int i = 0; i < m; ++i) {
    auto col = pht_.middleCols<2>(2 * i);
    col.noalias() = P_.leftCols<3>() * hv_[i].transpose();
    col.noalias() += P_.middleCols<2>(rows_[i]) * hm_[i].transpose();
  }

  // S = H P H^T + R, lower triangle of blocks (the Cholesky reads only that).
  s_.resize(d, d);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) {
      Eigen::Matrix2d b = hv_[i] * pht_.block<3, 2>(0, 2 * j);
      b.noalias() += hm_[i] * pht_.block<2, 2>(rows_[i], 2 * j);
      if (i == j) {
        b += pairings[i].R;
        b = 0.5 * (b + b.transpose()).eval();
      }
      if (!b.allFinite()) return false;
      s_.block<2, 2>(2 * i, 2 * j) = b;
    }
  }

  // In place: s_ becomes L with S = L L^T.
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(s_);
  if (llt.info() != Eigen::Success) return false;

  // W = P H^T L^-T, so K S K^T = W W^T and K v = W (L^-1 v).
  llt.matrixU().solveInPlace<Eigen::OnTheRight>(pht_);
  llt.matrixL().solveInPlace(v_);
  dx_.noalias() = pht_ * v_;
  if (!dx_.allFinite() || !pht_.allFinite()) return false;
  // A correction state's variance must stay positive (P_cc - W_c W_c^T): otherwise refuse the
  // update rather than leave a non-positive-definite filter.
  for (int i = 3; i < 3 + k_; ++i) {
    if (!(P_(i, i) - pht_.row(i).squaredNorm() > 0.0)) {
      ++refusals_;
      return false;
    }
  }

  x_ += dx_;
  x_(2) = wrapAngle(x_(2));
  for (int i = 0; i < k_; ++i) {
    const double c = x_(3 + i);
    x_(3 + i) = std::clamp(c, c_lower_(i), c_upper_(i));
    if (x_(3 + i) != c) ++clamps_;
  }
  P_.selfadjointView<Eigen::Lower>().rankUpdate(pht_, -1.0);
  mirrorLower(&P_);
  if (nis) *nis = v_.squaredNorm();
  return true;
}

LandmarkId EkfSlam::addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                                const RangeBearingModel& model, MeasurementKind kind) {
  if (!z.allFinite() || !R.allFinite()) return kNoLandmark;
  Matrix23d Gv;
  Eigen::Matrix2d Gz;
  const Eigen::Vector2d m = model.inverse(x_.head<3>(), z, kind, &Gv, &Gz);
  if (!m.allFinite() || !Gv.allFinite() || !Gz.allFinite()) return kNoLandmark;

  const Eigen::Index n = x_.size();
  const Eigen::Matrix3d Pvv = P_.topLeftCorner<3, 3>();
  Eigen::Matrix2d Pll = Gv * Pvv * Gv.transpose() + Gz * R * Gz.transpose();
  Pll = 0.5 * (Pll + Pll.transpose()).eval();

  x_.conservativeResize(n + 2);
  x_.tail<2>() = m;
  P_.conservativeResize(n + 2, n + 2);
  // cov(m, x) = Gv cov(xv, x): only the pose rows of P are needed.
  P_.block(n, 0, 2, n).noalias() = Gv * P_.topLeftCorner(3, n);
  P_.block(0, n, n, 2) = P_.block(n, 0, 2, n).transpose();
  P_.bottomRightCorner<2, 2>() = Pll;

  const LandmarkId id = next_id_++;
  index_of_[id] = static_cast<int>(ids_.size());
  ids_.push_back(id);
  return id;
}

LandmarkId EkfSlam::insertLandmark(const Eigen::Vector2d& position, const Eigen::Matrix2d& cov,
                                   LandmarkId id) {
  if (id < 0 || contains(id)) id = next_id_;
  next_id_ = std::max(next_id_, id + 1);
  const Eigen::Index n = x_.size();
  x_.conservativeResize(n + 2);
  x_.tail<2>() = position;
  P_.conservativeResize(n + 2, n + 2);
  P_.block(n, 0, 2, n).setZero();
  P_.block(0, n, n, 2).setZero();
  P_.bottomRightCorner<2, 2>() = 0.5 * (cov + cov.transpose());
  index_of_[id] = static_cast<int>(ids_.size());
  ids_.push_back(id);
  return id;
}

void EkfSlam::setState(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                       const std::vector<LandmarkId>& ids) {
  const Eigen::Index n = 3 + k_ + 2 * static_cast<Eigen::Index>(ids.size());
  if (mean.size() != n || covariance.rows() != n || covariance.cols() != n) {
    throw std::invalid_argument("EkfSlam::setState: mean " + std::to_string(mean.size()) +
                                ", covariance " + std::to_string(covariance.rows()) + "x" +
                                std::to_string(covariance.cols()) + " for " +
                                std::to_string(ids.size()) + " landmarks");
  }
  std::unordered_map<LandmarkId, int> index_of;
  LandmarkId next = 0;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] < 0 || !index_of.emplace(ids[k], static_cast<int>(k)).second) {
      throw std::invalid_argument("EkfSlam::setState: invalid or duplicate landmark id " +
                                  std::to_string(ids[k]));
    }
    next = std::max(next, ids[k] + 1);
  }
  x_ = mean;
  x_(2) = wrapAngle(x_(2));
  P_ = covariance;
  ids_ = ids;
  index_of_ = std::move(index_of);
  next_id_ = next;
}

bool EkfSlam::removeLandmark(LandmarkId id) {
  const int idx = indexOf(id);
  if (idx < 0) return false;
  const Eigen::Index n = x_.size();
  const Eigen::Index r = stateRow(idx);
  const Eigen::Index tail = n - r - 2;

  // One repack into the smaller matrix (a size change reallocates anyway).
  Eigen::MatrixXd P(n - 2, n - 2);
  P.topLeftCorner(r, r) = P_.topLeftCorner(r, r);
  P.topRightCorner(r, tail) = P_.topRightCorner(r, tail);
  P.bottomLeftCorner(tail, r) = P_.bottomLeftCorner(tail, r);
  P.bottomRightCorner(tail, tail) = P_.bottomRightCorner(tail, tail);
  P_.swap(P);
  x_.segment(r, tail) = x_.tail(tail).eval();
  x_.conservativeResize(n - 2);

  ids_.erase(ids_.begin() + idx);
  index_of_.erase(id);
  for (std::size_t k = idx; k < ids_.size(); ++k) index_of_[ids_[k]] = static_cast<int>(k);
  return true;
}

}  // namespace ekf_slam
