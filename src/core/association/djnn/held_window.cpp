// DJNN's held window. See held_window.h and docs/djnn.md.
#include "ekf_slam/core/association/djnn/held_window.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace ekf_slam {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// d pose_now / d pose_k of an odometry step (any model that adds a displacement turned by the
// heading): the position moves with the heading by the displacement turned 90 degrees.
Eigen::Matrix3d transition(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -(to.y() - from.y());
  F(1, 2) = to.x() - from.x();
  return F;
}
}  // namespace

void HeldWindow::clear() {
  window_.clear();
  held_.clear();
  scans_.clear();
}

bool HeldWindow::advance(const Eigen::Vector3d& pose, const Eigen::Matrix3d& P) {
  bool ok = true;
  if (!window_.empty()) {
    if (!have_last_) {
      ok = false;
    } else {
      const Eigen::Matrix3d F = transition(last_pose_, pose);
      Eigen::Matrix3d Q = P - F * last_P_ * F.transpose();
      Q = 0.5 * (Q + Q.transpose()).eval();
      // A prediction only adds noise; a correction (or anything else) shrinks some direction.
      const double tol = 1e-9 * (1.0 + P.trace());
      ok = Q.allFinite() &&
           Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(Q).eigenvalues().minCoeff() >= -tol;
      if (ok) window_.addMotion(F, Q);
    }
    if (!ok) clear();
  }
  have_last_ = true;
  last_pose_ = pose;
  last_P_ = P;
  return ok;
}

void HeldWindow::push(std::uint32_t scan, const Eigen::Vector3d& pose,
                      const std::vector<Held>& held) {
  if (held.empty() || window_.size() <= 0) return;
  std::vector<Observation> obs;
  for (const Held& h : held) obs.push_back(h.observation);
  window_.push(scan, pose, obs);
  held_[scan] = held;
  // Drop what the window dropped.
  const std::vector<CarriedScan> kept = window_.carried(pose);
  for (auto it = held_.begin(); it != held_.end();) {
    const bool in = std::any_of(kept.begin(), kept.end(),
                                [&](const CarriedScan& c) { return c.scan == it->first; });
    it = in ? std::next(it) : held_.erase(it);
  }
}

const std::vector<CarriedScan>& HeldWindow::scans(const Eigen::Vector3d& now) {
  scans_ = window_.carried(now);
  return scans_;
}

// --- the joint Gaussian ------------------------------------------------------------------------

WindowLikelihood::WindowLikelihood(const EkfSlam& ekf, const RangeBearingModel& model,
                                   const std::vector<CarriedScan>& scans)
    : ekf_(ekf), model_(model), scans_(scans) {
  const Eigen::Vector3d now = ekf.pose();
  for (const CarriedScan& s : scans) Finv_.push_back(transition(s.pose, now).inverse());
}

WindowLikelihood::Row WindowLikelihood::linearise(const WindowPairing& p) const {
  Row r;
  r.scan = p.scan;
  r.row = ekf_.stateRow(p.landmark);
  const Eigen::Vector3d pose = p.scan < 0 ? ekf_.pose() : scans_[p.scan].pose;
  Matrix23d H;
  const Eigen::Vector2d z_hat = model_.predict(pose, ekf_.landmark(p.landmark), p.kind, &H, &r.Hm);
  r.G = p.scan < 0 ? H : (H * Finv_[p.scan]).eval();
  r.v = RangeBearingModel::innovation(p.z, z_hat, p.kind);
  r.R = p.R;
  r.cost = p.cost;
  return r;
}

Eigen::Matrix2d WindowLikelihood::cross(const Row& a, const Row& b) const {
  const auto P = ekf_.covariance();
  Eigen::Matrix2d S = a.G * P.topLeftCorner<3, 3>() * b.G.transpose() +
                      a.G * P.block<3, 2>(0, b.row) * b.Hm.transpose() +
                      a.Hm * P.block<2, 3>(a.row, 0) * b.G.transpose() +
                      a.Hm * P.block<2, 2>(a.row, b.row) * b.Hm.transpose();
  // The odometry noise since the older of the two scans is in P_now but not in their poses.
  const int older = a.scan < 0 ? b.scan : (b.scan < 0 ? a.scan : std::min(a.scan, b.scan));
  if (older >= 0) S -= a.G * scans_[older].Q * b.G.transpose();
  return S;
}

bool WindowLikelihood::condition(const Row& a, Eigen::Vector2d* v, Eigen::Matrix2d* S,
                                 Eigen::MatrixXd* W) const {
  *S = cross(a, a) + a.R;
  *v = a.v;
  const int n = static_cast<int>(y_.size());
  if (n > 0) {
    Eigen::MatrixXd Sba(n, 2);
    for (std::size_t b = 0; b < rows_.size(); ++b) {
      Sba.block<2, 2>(2 * static_cast<Eigen::Index>(b), 0) = cross(rows_[b], a);
    }
    *W = L_.topLeftCorner(n, n).triangularView<Eigen::Lower>().solve(Sba);
    *S -= W->transpose() * *W;
    *v -= W->transpose() * y_;
  }
  *S = 0.5 * (*S + S->transpose()).eval();
  return S->allFinite() && S->determinant() > 0.0 && (*S)(0, 0) > 0.0;
}

double WindowLikelihood::conditionalCost(const WindowPairing& p, double* mahalanobis) const {
  const Row a = linearise(p);
  Eigen::Vector2d v;
  Eigen::Matrix2d S;
  Eigen::MatrixXd W;
  if (!condition(a, &v, &S, &W)) {
    if (mahalanobis) *mahalanobis = kInf;
    return kInf;
  }
  const double m = v.dot(S.inverse() * v);
  if (mahalanobis) *mahalanobis = m;
  return m + std::log(S.determinant()) + 2.0 * std::log(2.0 * M_PI) + a.cost;
}

double WindowLikelihood::add(const WindowPairing& p) {
  const Row a = linearise(p);
  Eigen::Vector2d v;
  Eigen::Matrix2d S;
  Eigen::MatrixXd W;
  if (!condition(a, &v, &S, &W)) return kInf;  // not added: it cannot be part of the hypothesis
  const Eigen::LLT<Eigen::Matrix2d> llt(S);
  if (llt.info() != Eigen::Success) return kInf;
  const int n = static_cast<int>(y_.size());
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n + 2, n + 2);
  if (n > 0) {
    L.topLeftCorner(n, n) = L_.topLeftCorner(n, n);
    L.block(n, 0, 2, n) = W.transpose();
  }
  const Eigen::Matrix2d Lc = llt.matrixL();
  L.block<2, 2>(n, n) = Lc;
  L_ = std::move(L);
  Eigen::VectorXd y(n + 2);
  y.head(n) = y_;
  y.tail<2>() = Lc.triangularView<Eigen::Lower>().solve(v);
  y_ = std::move(y);
  rows_.push_back(a);
  const double m = v.dot(S.inverse() * v);
  return m + std::log(S.determinant()) + 2.0 * std::log(2.0 * M_PI) + a.cost;
}

}  // namespace ekf_slam
