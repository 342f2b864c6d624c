// EKF-SLAM state and filter steps on a dense covariance.
#include "ekf_slam/core/filter/ekf_slam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

namespace {

// Grows a workspace to at least n doubles (never shrinks: the update allocates only while the
// map grows past its largest size so far).
double* workspace(std::vector<double>* w, std::size_t n) {
  if (w->size() < n) w->resize(std::max(n, w->size() + w->size() / 2));
  return w->data();
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
  dim_ = 0;
  upper_stale_ = false;
  reserveCovariance(3 + k);
  dim_ = 3 + k;
  auto P = this->P();
  P.setZero();
  P.topLeftCorner<3, 3>() = 0.5 * (pose_cov + pose_cov.transpose());
  P.block(3, 3, k, k) = correction.sigma.head(k).cwiseAbs2().asDiagonal();
  ids_.clear();
  index_of_.clear();
  first_.clear();
  clones_.clear();
  clone_tags_.clear();
  clone_first_.clear();
  prior_position_ = x_.head<2>();
  next_id_ = 0;
}

Eigen::Vector2d EkfSlam::correction() const {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  c.head(k_) = x_.segment(3, k_);
  return c;
}

Eigen::Matrix2d EkfSlam::correctionCovariance() const {
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  C.topLeftCorner(k_, k_) = storedCovariance().block(3, 3, k_, k_);
  return C;
}

void EkfSlam::replacePose(const Eigen::Vector3d& pose, const Eigen::Matrix3d& pose_cov) {
  x_.head<3>() = pose;
  x_(2) = wrapAngle(x_(2));
  prior_position_ = x_.head<2>();
  auto P = this->P();
  P.topLeftCorner<3, 3>() = 0.5 * (pose_cov + pose_cov.transpose());
  const Eigen::Index n = dim_ - 3;
  P.topRightCorner(3, n).setZero();
  P.bottomLeftCorner(n, 3).setZero();
}

void EkfSlam::mirrorLower() const {
  mirrorLowerTriangle(MatrixView(store_.data(), dim_, dim_, Eigen::OuterStride<>(store_.rows())));
  upper_stale_ = false;
}

void EkfSlam::reserveCovariance(Eigen::Index n) {
  const Eigen::Index cap = store_.rows();
  if (n <= cap) return;
  Eigen::MatrixXd grown(std::max(n, cap + cap / 2), std::max(n, cap + cap / 2));
  grown.topLeftCorner(dim_, dim_) = covariance();
  store_.swap(grown);
}

int EkfSlam::indexOf(LandmarkId id) const {
  const auto it = index_of_.find(id);
  return it == index_of_.end() ? -1 : it->second;
}

Eigen::Matrix3d EkfSlam::transition(const MotionStep& step) const {
  Eigen::Matrix3d F = step.F;
  if (linearisation_ == Linearisation::kFirstEstimate) {
    // Huang et al.'s Phi: the displacement from the prior position, so that the product of the
    // transitions since any time telescopes to J (p_now - p_then) with the same positions at
    // which H was evaluated: the global rotation stays in the null space of the observability
    // matrix. (A composed step's F is a product of such matrices: the same holds for it.)
    const Eigen::Vector2d d = step.pose.head<2>() - prior_position_;
    F(0, 2) = -d(1);
    F(1, 2) = d(0);
  }
  return F;
}

bool EkfSlam::predict(const MotionStep& step) {
  if (!step.pose.allFinite() || !step.F.allFinite() || !step.Q.allFinite()) return false;
  if (step.corrections != k_) return false;
  if (k_ > 0) return predictAugmented(step);
  const Eigen::Matrix3d F = transition(step);
  x_.head<3>() = step.pose;
  x_(2) = wrapAngle(x_(2));
  prior_position_ = x_.head<2>();

  auto P = this->P();
  const Eigen::Matrix3d Pvv = P.topLeftCorner<3, 3>();
  Eigen::Matrix3d Pn = F * Pvv * F.transpose() + step.Q;
  P.topLeftCorner<3, 3>() = 0.5 * (Pn + Pn.transpose());

  // Pose/map cross-covariance, one landmark at a time: fixed-size blocks, no temporaries.
  const Eigen::Index map_end = mapEnd();
  for (Eigen::Index r = 3; r < map_end; r += 2) {
    const Eigen::Matrix<double, 3, 2> c = F * P.block<3, 2>(0, r);
    P.block<3, 2>(0, r) = c;
    P.block<2, 3>(r, 0) = c.transpose();
  }
  // ... and with each clone (a clone does not move: its column is a landmark's).
  for (Eigen::Index r = map_end; r < dim_; r += 3) {
    const Eigen::Matrix3d c = F * P.block<3, 3>(0, r);
    P.block<3, 3>(0, r) = c;
    P.block<3, 3>(r, 0) = c.transpose();
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
  B.leftCols<3>() = transition(step);
  B.rightCols(k_) = step.Fc.leftCols(k_);
  Small A = Small::Identity(a, a);
  A.topRows<3>() = B;
  Small N = Small::Zero(a, a);
  N.topLeftCorner<3, 3>() = step.Q;
  N.topRightCorner(3, k_) = step.Qvc.leftCols(k_);
  N.bottomLeftCorner(k_, 3) = step.Qvc.leftCols(k_).transpose();
  N.bottomRightCorner(k_, k_) = step.Qc.topLeftCorner(k_, k_);
  auto P = this->P();
  const Small Paa = P.topLeftCorner(a, a);
  Small Pn = A * Paa * A.transpose() + N;
  P.topLeftCorner(a, a) = 0.5 * (Pn + Pn.transpose());

  x_.head<3>() = step.pose;
  x_(2) = wrapAngle(x_(2));
  prior_position_ = x_.head<2>();
  const Eigen::Index map_end = mapEnd();
  for (Eigen::Index r = a; r < map_end; r += 2) {
    const Eigen::Matrix<double, 3, 2> c = B * P.block(0, r, a, 2);
    P.block<3, 2>(0, r) = c;
    P.block<2, 3>(r, 0) = c.transpose();
  }
  for (Eigen::Index r = map_end; r < dim_; r += 3) {
    const Eigen::Matrix3d c = B * P.block(0, r, a, 3);
    P.block<3, 3>(0, r) = c;
    P.block<3, 3>(r, 0) = c.transpose();
  }
  return true;
}

bool EkfSlam::secondOrderTerms(int index, int pose_row, const RangeBearingModel& model,
                               MeasurementKind kind, Eigen::Vector2d* mean,
                               Eigen::Matrix2d* extra) const {
  if (!second_order_ || kind != MeasurementKind::kRangeBearing) return false;
  const ConstMatrixView P = storedCovariance();  // the blocks read here are current
  const int r = stateRow(index);
  const Eigen::Vector3d xv = x_.segment<3>(pose_row);
  // cov(landmark, pose) from the lower triangle (a clone's rows lie below the map's).
  const Matrix23d cross = pose_row < r ? Matrix23d(P.block<2, 3>(r, pose_row))
                                       : Matrix23d(P.block<3, 2>(pose_row, r).transpose());
  const Eigen::Matrix2d C = model.relativeCovariance(xv, P.block<3, 3>(pose_row, pose_row), cross,
                                                     landmarkCovariance(index));
  RangeBearingModel::rangeBearingSecondOrder(x_.segment<2>(r) - model.sensorPose(xv).head<2>(), C,
                                             mean, extra);
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

  rows_.resize(m);
  pose_rows_.resize(m);
  hv_.resize(m);
  hm_.resize(m);
  r_.resize(m);
  Eigen::Map<Eigen::VectorXd> v(workspace(&v_, d), d);
  const bool first = linearisation_ == Linearisation::kFirstEstimate;
  for (int i = 0; i < m; ++i) {
    Eigen::Vector2d vi;
    if (!linearise(pairings[i], model, first, &rows_[i], &pose_rows_[i], &hv_[i], &hm_[i], &r_[i],
                   &vi)) {
      return false;
    }
    v.segment<2>(2 * i) = vi;
  }

  // P H^T: each 2-row block of H has a pose part and one landmark part, so it costs O(n m).
  auto P = this->P();
  Eigen::Map<Eigen::MatrixXd> pht(workspace(&pht_, n * d), n, d);
  for (int i = 0; i < m; ++i) {
    auto col = pht.middleCols<2>(2 * i);
    const Eigen::Index r = rows_[i];
    const Eigen::Index c = pose_rows_[i];
    if (c == 0) {
      col.noalias() = P.leftCols<3>() * hv_[i].transpose();
    } else {
      // A clone's column, like a landmark's, from the current part (clones follow the map).
      col.topRows(c).noalias() = P.block(c, 0, 3, c).transpose() * hv_[i].transpose();
      col.bottomRows(n - c).noalias() = P.block(c, c, n - c, 3) * hv_[i].transpose();
    }
    // Column r of P from the current part: row r of the lower triangle above the diagonal.
    col.topRows(r).noalias() += P.block(r, 0, 2, r).transpose() * hm_[i].transpose();
    col.bottomRows(n - r).noalias() += P.block(r, r, n - r, 2) * hm_[i].transpose();
  }

  // S = H P H^T + R, lower triangle of blocks (the Cholesky reads only that).
  Eigen::Map<Eigen::MatrixXd> s(workspace(&s_, d * d), d, d);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) {
      Eigen::Matrix2d b = hv_[i] * pht.block<3, 2>(pose_rows_[i], 2 * j);
      b.noalias() += hm_[i] * pht.block<2, 2>(rows_[i], 2 * j);
      if (i == j) {
        b += r_[i];
        b = 0.5 * (b + b.transpose()).eval();
      }
      if (!b.allFinite()) return false;
      s.block<2, 2>(2 * i, 2 * j) = b;
    }
  }

  // In place: s becomes L with S = L L^T.
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(s);
  if (llt.info() != Eigen::Success) return false;

  // W = P H^T L^-T, so K S K^T = W W^T and K v = W (L^-1 v).
  llt.matrixU().solveInPlace<Eigen::OnTheRight>(pht);
  llt.matrixL().solveInPlace(v);
  Eigen::Map<Eigen::VectorXd> dx(workspace(&dx_, n), n);
  dx.noalias() = pht * v;
  // W finite: x * 0 is 0 for finite x, NaN otherwise; the sum vectorises, where allFinite()
  // stops at the first non-finite element one scalar at a time (a tenth of update()'s own time).
  if (!dx.allFinite() || !std::isfinite((pht.array() * 0.0).sum())) return false;
  // A correction state's variance must stay positive (P_cc - W_c W_c^T): otherwise refuse the
  // update rather than leave a non-positive-definite filter.
  for (int i = 3; i < 3 + k_; ++i) {
    if (!(P(i, i) - pht.row(i).squaredNorm() > 0.0)) {
      ++refusals_;
      return false;
    }
  }

  const bool invariant = linearisation_ == Linearisation::kInvariant;
  if (invariant) {
    retractInvariant(dx, &moved_);
  } else {
    x_ += dx;
  }
  x_(2) = wrapAngle(x_(2));
  for (int i = 0; i < k_; ++i) {
    const double c = x_(3 + i);
    x_(3 + i) = std::clamp(c, c_lower_(i), c_upper_(i));
    if (x_(3 + i) != c) ++clamps_;
  }
  // Lower triangle only (the floor: N^2 d flops); of the upper one, keep the vehicle rows and
  // each landmark's 2 x 2 block current (O(n)), the rest waits for covariance().
  if (invariant) {
    // M (P - W W^T) M^T: the pose's rank-2 term rides in the downdate's pass over P,
    // as P -= [W, d0, v0] [W, -v0, -d0]^T; the clones' terms touch two rows each.
    invariantTerms(pht, moved_);
    Eigen::Map<Eigen::MatrixXd> a(workspace(&inv_a_, n * (d + 2)), n, d + 2);
    Eigen::Map<Eigen::MatrixXd> b(workspace(&inv_b_, n * (d + 2)), n, d + 2);
    a.leftCols(d) = pht;
    b.leftCols(d) = pht;
    a.col(d) = d0_;
    a.col(d + 1) = v0_;
    b.col(d) = -v0_;
    b.col(d + 1) = -d0_;
    lowerProductDowndate(P, a, b, &packed_w_);
    applyInvariantCloneTerms(moved_);
  } else {
    lowerRankDowndate(P, pht, &packed_w_);
  }
  const Eigen::Index a = 3 + k_;
  P.topLeftCorner(a, a).triangularView<Eigen::StrictlyUpper>() = P.topLeftCorner(a, a).transpose();
  P.block(0, a, a, n - a) = P.block(a, 0, n - a, a).transpose();
  mirrorDiagonalBlocks();
  upper_stale_ = n > a;
  const double rank_flops = rankDowndateFlops(n, d);
  ++stats_.updates;
  stats_.rank_flops += rank_flops;
  stats_.flops += rank_flops + static_cast<double>(n) * d * (12.0 + d);
  stats_.weighted_n += rank_flops * static_cast<double>(n);
  stats_.weighted_d += rank_flops * static_cast<double>(d);
  if (record_shapes_) ++stats_.shapes[{static_cast<int>(n), static_cast<int>(d)}];
  if (nis) *nis = v.squaredNorm();
  return true;
}

namespace {

// J p, the 90 degree rotation: d/de of R(e) p at e = 0.
Eigen::Vector2d perp(const Eigen::Vector2d& p) { return Eigen::Vector2d(-p(1), p(0)); }

// exp of (phi, u) in SE(2) applied to position p: R(phi) p + V(phi) u.
Eigen::Vector2d exponentialMove(double phi, const Eigen::Vector2d& u, const Eigen::Vector2d& p) {
  const double s = std::sin(phi), c = std::cos(phi);
  // V = [a -b; b a] with a = sin(phi) / phi, b = (1 - cos(phi)) / phi (series near 0).
  const double a = std::abs(phi) < 1e-6 ? 1.0 - phi * phi / 6.0 : s / phi;
  const double b = std::abs(phi) < 1e-6 ? 0.5 * phi : (1.0 - c) / phi;
  return Eigen::Vector2d(c * p(0) - s * p(1) + a * u(0) - b * u(1),
                         s * p(0) + c * p(1) + b * u(0) + a * u(1));
}

}  // namespace

bool EkfSlam::linearise(const Pairing& p, const RangeBearingModel& model, bool first, int* row,
                        int* pose_row, Matrix23d* Hv, Eigen::Matrix2d* Hm, Eigen::Matrix2d* R,
                        Eigen::Vector2d* v) const {
  const int idx = indexOf(p.id);
  if (idx < 0 || !p.z.allFinite() || !p.R.allFinite()) return false;
  *row = stateRow(idx);
  int clone = -1;
  if (p.clone != kNoClone) {
    const auto it = std::find(clones_.begin(), clones_.end(), p.clone);
    if (it == clones_.end()) return false;
    clone = static_cast<int>(it - clones_.begin());
  }
  *pose_row = clone < 0 ? 0 : mapEnd() + 3 * clone;
  const Eigen::Vector3d xv = x_.segment<3>(*pose_row);
  // The innovation always from the current estimate; only H's linearisation point moves.
  Eigen::Vector2d z_hat = first ? model.predict(xv, x_.segment<2>(*row), p.kind)
                                : model.predict(xv, x_.segment<2>(*row), p.kind, Hv, Hm);
  if (first) {
    model.predict(clone < 0 ? xv : Eigen::Vector3d(clone_first_[clone]), first_[idx], p.kind, Hv,
                  Hm);
  }
  *R = p.R;
  Eigen::Vector2d mean;
  Eigen::Matrix2d extra;
  if (secondOrderTerms(idx, *pose_row, model, p.kind, &mean, &extra)) {
    z_hat += mean;
    *R += extra;
  }
  if (!z_hat.allFinite() || !Hv->allFinite() || !Hm->allFinite()) return false;
  *v = RangeBearingModel::innovation(p.z, z_hat, p.kind);
  return true;
}

bool EkfSlam::innovation(const Pairing& p, const RangeBearingModel& model, Eigen::Vector2d* v,
                         Eigen::Matrix2d* S) const {
  int r = 0, c = 0;
  Matrix23d Hv;
  Eigen::Matrix2d Hm, R;
  if (!linearise(p, model, false, &r, &c, &Hv, &Hm, &R, v)) return false;
  // Only the current part of P is read (the lower triangle, and the pose rows).
  const ConstMatrixView P = storedCovariance();
  const Eigen::Matrix3d Pvv = Eigen::Matrix3d(P.block<3, 3>(c, c)).selfadjointView<Eigen::Lower>();
  const Eigen::Matrix2d Pmm = Eigen::Matrix2d(P.block<2, 2>(r, r)).selfadjointView<Eigen::Lower>();
  const Eigen::Matrix<double, 2, 3> Pmv =
      r > c ? Eigen::Matrix<double, 2, 3>(P.block<2, 3>(r, c))
            : Eigen::Matrix<double, 2, 3>(P.block<3, 2>(c, r).transpose());
  const Eigen::Matrix2d cross = Hm * Pmv * Hv.transpose();
  Eigen::Matrix2d s =
      Hv * Pvv * Hv.transpose() + cross + cross.transpose() + Hm * Pmm * Hm.transpose() + R;
  s = 0.5 * (s + s.transpose()).eval();
  *S = s;
  return v->allFinite() && S->allFinite();
}

void EkfSlam::retractInvariant(const Eigen::Ref<const Eigen::VectorXd>& dx,
                               Eigen::VectorXd* moved) {
  // dx is T(x) xi to first order: a position's xi is its dx less the rotation part phi J p.
  moved->setZero(dim_);
  const auto move = [&](double phi, Eigen::Index row) {
    const Eigen::Vector2d p = x_.segment<2>(row);
    const Eigen::Vector2d u = dx.segment<2>(row) - phi * perp(p);
    x_.segment<2>(row) = exponentialMove(phi, u, p);
    moved->segment<2>(row) = x_.segment<2>(row) - p;
  };
  move(dx(2), 0);
  x_(2) += dx(2);
  x_.segment(3, k_) += dx.segment(3, k_);  // the correction states are not positions
  const Eigen::Index map_end = mapEnd();
  for (Eigen::Index r = 3 + k_; r < map_end; r += 2) move(dx(2), r);
  for (Eigen::Index r = map_end; r < dim_; r += 3) {
    move(dx(r + 2), r);
    x_(r + 2) = wrapAngle(x_(r + 2) + dx(r + 2));
  }
}

void EkfSlam::invariantTerms(const Eigen::Ref<const Eigen::MatrixXd>& W,
                             const Eigen::VectorXd& moved) {
  // P_std = T(x) P_xi T(x)^T with T = I + sum_b c_b(x) e_b^T, c_b = J (positions following
  // heading b): the pose's heading for the pose's and the landmarks' positions, each clone's for
  // its own. P_xi is unchanged by the retraction, so the downdated P' = P - W W^T becomes
  // M P' M^T with M = T(x+) T(x-)^-1 = I + sum_b d_b e_b^T, d_b = J moved_b. Written out, with
  // a_b = P' e_b and s_bc = P'(b, c): M P' M^T = P' + sum_b (d_b v_b^T + v_b d_b^T) where
  // v_0 = a_0 + s_00 d_0 / 2 for the pose and v_c = a_c + s_0c d_0 + sum_k s_ck d_k / 2 for a
  // clone (the pose-clone cross terms go to the clone; the sum is symmetric).
  const ConstMatrixView P = storedCovariance();
  const Eigen::Index n = dim_, map_end = mapEnd();
  const int clones = static_cast<int>(clones_.size());
  // Columns of P' at a heading: P's from its lower triangle (the part current now), less W's.
  const auto column = [&](Eigen::Index c, Eigen::Ref<Eigen::VectorXd> a) {
    a.head(c) = P.row(c).head(c).transpose();
    a.tail(n - c) = P.col(c).tail(n - c);
    a.noalias() -= W * W.row(c).transpose();
  };
  d0_.setZero(n);
  d0_.segment<2>(0) = perp(moved.segment<2>(0));
  for (Eigen::Index r = 3 + k_; r < map_end; r += 2) d0_.segment<2>(r) = perp(moved.segment<2>(r));
  heading_col_.resize(n);
  column(2, heading_col_);
  v0_ = heading_col_ + 0.5 * heading_col_(2) * d0_;
  clone_cols_.resize(n, clones);
  for (int j = 0; j < clones; ++j) column(map_end + 3 * j + 2, clone_cols_.col(j));
}

void EkfSlam::applyInvariantCloneTerms(const Eigen::VectorXd& moved) {
  const int clones = static_cast<int>(clones_.size());
  if (clones == 0) return;
  auto P = this->P();
  const Eigen::Index n = dim_, map_end = mapEnd();
  // v_c for every clone (columns of clone_v_) and d_c's two rows (columns of clone_d_).
  clone_v_.resize(n, clones);
  clone_d_.resize(2, clones);
  for (int j = 0; j < clones; ++j) clone_d_.col(j) = perp(moved.segment<2>(map_end + 3 * j));
  for (int j = 0; j < clones; ++j) {
    const Eigen::Index r = map_end + 3 * j;
    auto v = clone_v_.col(j);
    v = clone_cols_.col(j) + heading_col_(r + 2) * d0_;
    for (int k = 0; k < clones; ++k)
      v.segment<2>(map_end + 3 * k) += 0.5 * clone_cols_(r + 2, k) * clone_d_.col(k);
  }
  // P += sum_c (d_c v_c^T + v_c d_c^T) on the lower triangle. d_c v_c^T changes clone c's
  // position rows: in each column, the clone rows at or below the diagonal (column by column, so
  // that each column's clone rows are read once).
  for (Eigen::Index k = 0; k < n; ++k) {
    for (int j = 0; j < clones; ++j) {
      const Eigen::Index r = map_end + 3 * j;
      if (r + 1 < k) continue;
      if (r >= k) P(r, k) += clone_d_(0, j) * clone_v_(k, j);
      P(r + 1, k) += clone_d_(1, j) * clone_v_(k, j);
    }
  }
  // v_c d_c^T changes clone c's position columns, below the diagonal.
  for (int j = 0; j < clones; ++j) {
    for (int t = 0; t < 2; ++t) {
      const Eigen::Index q = map_end + 3 * j + t;
      P.col(q).tail(n - q) += clone_d_(t, j) * clone_v_.col(j).tail(n - q);
    }
  }
}

LandmarkId EkfSlam::addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                                const RangeBearingModel& model, MeasurementKind kind) {
  if (!z.allFinite() || !R.allFinite()) return kNoLandmark;
  Matrix23d Gv;
  Eigen::Matrix2d Gz;
  Eigen::Vector2d m = model.inverse(x_.head<3>(), z, kind, &Gv, &Gz);
  if (!m.allFinite() || !Gv.allFinite() || !Gz.allFinite()) return kNoLandmark;
  if (linearisation_ == Linearisation::kFirstEstimate) {
    // The same rule as the propagation's: the pose's heading column from the prior position
    // (where this scan's H was evaluated), so that the rotation direction [I, J p_prior] of the
    // pose maps onto [I, J m] of the new landmark, m its first estimate.
    const Eigen::Vector2d d = m - prior_position_;
    Gv(0, 2) = -d(1);
    Gv(1, 2) = d(0);
  }

  const Eigen::Index n = x_.size();
  const Eigen::Matrix3d Pvv = storedCovariance().topLeftCorner<3, 3>();
  Eigen::Matrix2d Pll = Gv * Pvv * Gv.transpose() + Gz * R * Gz.transpose();
  if (second_order_ && kind == MeasurementKind::kRangeBearing) {
    // The beam's world direction carries the heading's variance as well as the bearing's.
    Eigen::Matrix2d C = R;
    C(1, 1) += Pvv(2, 2);
    Eigen::Vector2d mean;
    Eigen::Matrix2d extra;
    RangeBearingModel::polarSecondOrder(z(0), x_(2) + model.sensorOffset()(2) + z(1), C, &mean,
                                        &extra);
    m += mean;
    Pll += extra;
  }
  Pll = 0.5 * (Pll + Pll.transpose()).eval();
  if (clones_.empty()) {
    x_.conservativeResize(n + 2);
    x_.tail<2>() = m;
    reserveCovariance(n + 2);
    dim_ = n + 2;
    auto P = this->P();
    // cov(m, x) = Gv cov(xv, x): only the pose rows of P are needed.
    P.block(n, 0, 2, n).noalias() = Gv * P.topLeftCorner(3, n);
    P.block(0, n, n, 2) = P.block(n, 0, 2, n).transpose();
    P.bottomRightCorner<2, 2>() = Pll;
    return appendId(m);
  }
  const Eigen::MatrixXd cross = Gv * storedCovariance().topLeftCorner(3, n);
  return appendLandmark(m, Pll, cross, m);
}

LandmarkId EkfSlam::appendId(const Eigen::Vector2d& first) {
  const LandmarkId id = next_id_++;
  index_of_[id] = static_cast<int>(ids_.size());
  ids_.push_back(id);
  first_.push_back(first);
  return id;
}

LandmarkId EkfSlam::appendLandmark(const Eigen::Vector2d& m, const Eigen::Matrix2d& Pll,
                                   const Eigen::MatrixXd& cross, const Eigen::Vector2d& first) {
  // Before the clones: rows [at, at + 2) of the grown state.
  const Eigen::Index at = mapEnd();
  const Eigen::Index n = dim_;
  openRows(at, 2);
  x_.segment<2>(at) = m;
  auto P = this->P();
  P.block(at, 0, 2, at) = cross.leftCols(at);
  P.block(0, at, at, 2) = cross.leftCols(at).transpose();
  P.block(at, at + 2, 2, n - at) = cross.rightCols(n - at);
  P.block(at + 2, at, n - at, 2) = cross.rightCols(n - at).transpose();
  P.block<2, 2>(at, at) = Pll;
  return appendId(first);
}

LandmarkId EkfSlam::insertLandmark(const Eigen::Vector2d& position, const Eigen::Matrix2d& cov,
                                   LandmarkId id) {
  if (id < 0 || contains(id)) id = next_id_;
  next_id_ = std::max(next_id_, id + 1);
  if (!clones_.empty()) {
    const LandmarkId next = next_id_;
    next_id_ = id;
    appendLandmark(position, 0.5 * (cov + cov.transpose()), Eigen::MatrixXd::Zero(2, dim_),
                   position);
    next_id_ = next;
    return id;
  }
  const Eigen::Index n = x_.size();
  x_.conservativeResize(n + 2);
  x_.tail<2>() = position;
  reserveCovariance(n + 2);
  dim_ = n + 2;
  auto P = this->P();
  P.block(n, 0, 2, n).setZero();
  P.block(0, n, n, 2).setZero();
  P.bottomRightCorner<2, 2>() = 0.5 * (cov + cov.transpose());
  index_of_[id] = static_cast<int>(ids_.size());
  ids_.push_back(id);
  first_.push_back(position);
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
  clones_.clear();
  clone_tags_.clear();
  clone_first_.clear();
  x_ = mean;
  x_(2) = wrapAngle(x_(2));
  dim_ = 0;
  upper_stale_ = false;
  reserveCovariance(n);
  dim_ = n;
  P() = covariance;
  ids_ = ids;
  index_of_ = std::move(index_of);
  next_id_ = next;
  prior_position_ = x_.head<2>();
  first_.resize(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) first_[k] = landmark(static_cast<int>(k));
}

void EkfSlam::closeRows(Eigen::Index at, Eigen::Index count) {
  const Eigen::Index n = dim_;
  const Eigen::Index tail = n - at - count;
  // In place, no reallocation: rows below the gap move up in every column; columns right of it
  // move left. Columns are visited left to right, so nothing is overwritten before it has moved.
  double* d = store_.data();
  const Eigen::Index ld = store_.rows();
  for (Eigen::Index c = 0; c < n; ++c) {
    if (c >= at && c < at + count) continue;
    const double* src = d + c * ld;
    double* dst = d + (c < at ? c : c - count) * ld;
    if (dst != src) std::copy(src, src + at, dst);
    std::copy(src + at + count, src + n, dst + at);
  }
  dim_ = n - count;
  x_.segment(at, tail) = x_.tail(tail).eval();
  x_.conservativeResize(n - count);
}

void EkfSlam::openRows(Eigen::Index at, Eigen::Index count) {
  const Eigen::Index n = dim_;
  reserveCovariance(n + count);
  x_.conservativeResize(n + count);
  x_.segment(at + count, n - at) = x_.segment(at, n - at).eval();
  x_.segment(at, count).setZero();
  // Columns right to left, so nothing is overwritten before it has moved.
  double* d = store_.data();
  const Eigen::Index ld = store_.rows();
  for (Eigen::Index c = n - 1; c >= 0; --c) {
    double* src = d + c * ld;
    double* dst = d + (c < at ? c : c + count) * ld;
    std::copy_backward(src + at, src + n, dst + n + count);
    if (dst != src) std::copy(src, src + at, dst);
    std::fill(dst + at, dst + at + count, 0.0);
  }
  for (Eigen::Index c = at; c < at + count; ++c) std::fill(d + c * ld, d + c * ld + n + count, 0.0);
  dim_ = n + count;
}

void EkfSlam::mirrorDiagonalBlocks() {
  auto P = this->P();
  const Eigen::Index map_end = mapEnd();
  for (Eigen::Index r = 3 + k_; r < map_end; r += 2) P(r, r + 1) = P(r + 1, r);
  for (Eigen::Index r = map_end; r < dim_; r += 3) {
    P(r, r + 1) = P(r + 1, r);
    P(r, r + 2) = P(r + 2, r);
    P(r + 1, r + 2) = P(r + 2, r + 1);
  }
}

CloneId EkfSlam::addClone(double tag) {
  const Eigen::Index n = dim_;
  openRows(n, 3);
  x_.segment<3>(n) = x_.head<3>();
  auto P = this->P();
  // cov(clone, x) = cov(pose, x): the vehicle rows are current in every column.
  P.block(n, 0, 3, n) = P.topLeftCorner(3, n);
  P.block(0, n, n, 3) = P.topLeftCorner(3, n).transpose();
  P.block<3, 3>(n, n) = P.topLeftCorner<3, 3>();
  const CloneId id = next_clone_++;
  clones_.push_back(id);
  clone_tags_.push_back(tag);
  clone_first_.push_back(x_.head<3>());
  return id;
}

CloneId EkfSlam::findClone(double tag) const {
  for (std::size_t j = clones_.size(); j-- > 0;) {
    if (clone_tags_[j] == tag) return clones_[j];
  }
  return kNoClone;
}

int EkfSlam::cloneRow(CloneId id) const {
  const auto it = std::find(clones_.begin(), clones_.end(), id);
  return it == clones_.end() ? -1 : mapEnd() + 3 * static_cast<int>(it - clones_.begin());
}

Eigen::Vector3d EkfSlam::clonePose(CloneId id) const {
  const int r = cloneRow(id);
  return r < 0 ? Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())
               : Eigen::Vector3d(x_.segment<3>(r));
}

bool EkfSlam::restorePose(CloneId id) {
  const int r = cloneRow(id);
  if (r < 0) return false;
  mirrorLower();  // both triangles current: the rows are copied whole
  auto P = this->P();
  for (Eigen::Index j = 3; j < dim_; ++j) {
    if (j >= r && j < r + 3) continue;
    const Eigen::Vector3d c = P.block<3, 1>(r, j);
    P.block<3, 1>(0, j) = c;
    P.block<1, 3>(j, 0) = c.transpose();
  }
  const Eigen::Matrix3d Pcc = P.block<3, 3>(r, r);
  P.topLeftCorner<3, 3>() = Pcc;
  x_.head<3>() = x_.segment<3>(r);
  prior_position_ = x_.head<2>();
  return removeClone(id);
}

bool EkfSlam::removeClone(CloneId id) {
  const auto it = std::find(clones_.begin(), clones_.end(), id);
  if (it == clones_.end()) return false;
  const int j = static_cast<int>(it - clones_.begin());
  closeRows(mapEnd() + 3 * j, 3);
  clones_.erase(it);
  clone_tags_.erase(clone_tags_.begin() + j);
  clone_first_.erase(clone_first_.begin() + j);
  return true;
}

void EkfSlam::removeAllClones() {
  if (clones_.empty()) return;
  closeRows(mapEnd(), dim_ - mapEnd());
  clones_.clear();
  clone_tags_.clear();
  clone_first_.clear();
}

bool EkfSlam::removeLandmark(LandmarkId id) {
  const int idx = indexOf(id);
  if (idx < 0) return false;
  closeRows(stateRow(idx), 2);

  ids_.erase(ids_.begin() + idx);
  first_.erase(first_.begin() + idx);
  index_of_.erase(id);
  for (std::size_t k = idx; k < ids_.size(); ++k) index_of_[ids_[k]] = static_cast<int>(k);
  return true;
}

}  // namespace ekf_slam
