#include "ekf_slam/core/smoothing/batch_smoother.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

Eigen::Vector3d relativePose(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             Eigen::Matrix3d* J_a, Eigen::Matrix3d* J_b) {
  const Eigen::Matrix2d Rt = rotation2d(a.z()).transpose();
  const Eigen::Vector2d d = b.head<2>() - a.head<2>();
  const Eigen::Vector2d t = Rt * d;
  if (J_a) {
    const double c = std::cos(a.z()), s = std::sin(a.z());
    J_a->setZero();
    J_a->topLeftCorner<2, 2>() = -Rt;
    (*J_a)(0, 2) = -s * d.x() + c * d.y();  // d(Rt d) / d yaw_a
    (*J_a)(1, 2) = -c * d.x() - s * d.y();
    (*J_a)(2, 2) = -1.0;
  }
  if (J_b) {
    J_b->setZero();
    J_b->topLeftCorner<2, 2>() = Rt;
    (*J_b)(2, 2) = 1.0;
  }
  return {t.x(), t.y(), wrapAngle(b.z() - a.z())};
}

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;

// One observation residual: scan pose i, landmark column k.
struct ObservationTerm {
  int scan;
  int index;  // in the scan's observations
  int landmark;
  Eigen::Vector2d z;
  Eigen::Matrix2d W;  // R^-1
  MeasurementKind kind;
};

// An odometry link from scan i - 1 to scan i, or a prior on scan i.
struct PoseTerm {
  int scan;
  Eigen::Vector3d mean;  // motion (link) or pose (prior)
  Eigen::Matrix3d W;
};

// Inverse of a covariance floored at min_variance; false when it is not a covariance.
bool information(Eigen::MatrixXd C, double min_variance, Eigen::MatrixXd* W) {
  if (!C.allFinite()) return false;
  C = 0.5 * (C + C.transpose());
  C.diagonal().array() += min_variance;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(C);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || (ldlt.vectorD().array() <= 0.0).any())
    return false;
  *W = ldlt.solve(Eigen::MatrixXd::Identity(C.rows(), C.cols()));
  return W->allFinite();
}

// Adds block M = Jp^T W Jq at (rows p, cols q) to the lower triangle (p >= q as offsets).
template <class A, class B, class C>
void addLower(Triplets* t, int p, int q, const A& Jp, const B& W, const C& Jq) {
  const auto M = (Jp.transpose() * W * Jq).eval();  // fixed-size: no allocation per term
  for (int r = 0; r < M.rows(); ++r)
    for (int c = 0; c < M.cols(); ++c)
      if (p + r >= q + c) t->emplace_back(p + r, q + c, M(r, c));
}

// The entries of N^-1 on the sparsity pattern of N's factor (Takahashi's equations): every block
// a residual couples is there, at the cost of one pass over the factor (sum of its squared column
// counts) instead of a solve per unknown. N = P^T L D L^T P, L unit lower triangular.
class SelectedInverse {
 public:
  template <class Solver>
  explicit SelectedInverse(const Solver& solver)
      : L_(solver.matrixL().nestedExpression()), d_(solver.vectorD()) {
    const auto& P = solver.permutationP();
    const int n = static_cast<int>(d_.size());
    perm_.resize(n);
    for (int i = 0; i < n; ++i) perm_[i] = P.size() > 0 ? P.indices()(i) : i;
    z_.assign(L_.nonZeros(), 0.0);
    diag_.resize(n);
    const int* outer = L_.outerIndexPtr();
    const int* rows = L_.innerIndexPtr();
    const double* values = L_.valuePtr();
    // Column j from the last: its entries need only those of the columns after it (the rows of
    // a column are a clique of the filled pattern, so every Z_ik looked up is stored).
    for (int j = n - 1; j >= 0; --j) {
      const int begin = outer[j], end = outer[j] + columnCount(j);
      for (int a = end - 1; a >= begin; --a) {
        const int i = rows[a];
        double sum = 0.0;
        for (int b = begin; b < end; ++b) sum += values[b] * permuted(rows[b], i);
        z_[a] = -sum;
      }
      double sum = 0.0;
      for (int b = begin; b < end; ++b) sum += values[b] * z_[b];
      diag_(j) = 1.0 / d_(j) - sum;
    }
  }

  /// (N^-1)(i, j) for i, j coupled in N (or on the factor's pattern).
  double operator()(int i, int j) const { return permuted(perm_[i], perm_[j]); }

 private:
  int columnCount(int j) const {
    const int* nnz = L_.innerNonZeroPtr();
    return nnz ? nnz[j] : L_.outerIndexPtr()[j + 1] - L_.outerIndexPtr()[j];
  }
  double permuted(int i, int j) const {
    if (i == j) return diag_(i);
    const int col = std::min(i, j), row = std::max(i, j);
    const int* rows = L_.innerIndexPtr();
    const int* begin = rows + L_.outerIndexPtr()[col];
    const int* end = begin + columnCount(col);
    const int* it = std::lower_bound(begin, end, row);
    if (it == end || *it != row) return 0.0;  // not on the pattern: not asked for
    return z_[it - rows];
  }

  const Eigen::SparseMatrix<double>& L_;
  Eigen::VectorXd d_;
  std::vector<int> perm_;
  std::vector<double> z_;
  Eigen::VectorXd diag_;
};

class Problem {
 public:
  Problem(const std::vector<SmoothingScan>& scans, const std::vector<SmoothingLandmark>& landmarks,
          const RangeBearingModel& model, const SmootherParams& params, SmoothingResult* result)
      : model_(model), poses_(static_cast<int>(scans.size())) {
    std::unordered_map<LandmarkId, int> input_index;
    for (std::size_t k = 0; k < landmarks.size(); ++k) input_index[landmarks[k].id] = k;
    // Only landmarks with an observation are unknowns (the others keep the filter's estimate).
    std::vector<int> column(landmarks.size(), -1);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      for (std::size_t j = 0; j < scans[i].observations.size(); ++j) {
        const SmoothingObservation& o = scans[i].observations[j];
        const auto it = input_index.find(o.landmark);
        if (it == input_index.end()) {
          ++result->dropped_observations;
          continue;
        }
        int& col = column[it->second];
        if (col < 0) {
          col = static_cast<int>(landmark_input_.size());
          landmark_input_.push_back(it->second);
        }
        Eigen::MatrixXd W;
        if (!information(o.R, 0.0, &W)) {
          error_ = "scan " + std::to_string(i) + ": an observation's covariance is not positive";
          return;
        }
        observations_.push_back({static_cast<int>(i), static_cast<int>(j), col, o.z, W, o.kind});
      }
      Eigen::MatrixXd W;
      const bool link = scans[i].linked && i > 0;
      if (!information(link ? scans[i].motion_covariance : scans[i].pose_covariance,
                       params.min_variance, &W)) {
        error_ = "scan " + std::to_string(i) +
                 (link ? ": its odometry covariance" : ": its pose covariance") +
                 " is not a covariance";
        return;
      }
      (link ? links_ : priors_)
          .push_back({static_cast<int>(i), link ? scans[i].motion : scans[i].pose, W});
    }
    result->observations = observations_.size();
    const std::size_t residuals = 2 * observations_.size() + 3 * (links_.size() + priors_.size());
    result->degrees_of_freedom = residuals > unknowns() ? residuals - unknowns() : 0;
  }

  const std::string& error() const { return error_; }
  std::size_t unknowns() const { return 3 * poses_ + 2 * landmark_input_.size(); }
  const std::vector<int>& landmarkInput() const { return landmark_input_; }
  int landmarkOffset(int col) const { return 3 * poses_ + 2 * col; }
  // The last evaluate()'s cost of each kind per scalar residual.
  double odometryCostPerResidual() const {
    return links_.empty() ? 0.0 : odometry_cost_ / (3.0 * links_.size());
  }
  double observationCostPerResidual() const {
    return observations_.empty() ? 0.0 : observation_cost_ / (2.0 * observations_.size());
  }

  // The sum of squared Mahalanobis residuals at x; with A and b, also the normal equations
  // A dx = b of the linearisation (A's lower triangle).
  double evaluate(const Eigen::VectorXd& x, Sparse* A = nullptr, Eigen::VectorXd* b = nullptr) {
    double cost = 0.0;
    odometry_cost_ = observation_cost_ = 0.0;
    if (A) {
      triplets_.clear();
      b->setZero(x.size());
    }
    for (const PoseTerm& p : priors_) {
      const int o = 3 * p.scan;
      Eigen::Vector3d v = p.mean - x.segment<3>(o);
      v.z() = wrapAngle(v.z());
      cost += v.dot(p.W * v);
      if (!A) continue;
      addLower(&triplets_, o, o, Eigen::Matrix3d::Identity(), p.W, Eigen::Matrix3d::Identity());
      b->segment<3>(o) += p.W * v;
    }
    for (const PoseTerm& l : links_) {
      const int oa = 3 * (l.scan - 1), ob = 3 * l.scan;
      Eigen::Matrix3d Ja, Jb;
      Eigen::Vector3d v = l.mean - relativePose(x.segment<3>(oa), x.segment<3>(ob), &Ja, &Jb);
      v.z() = wrapAngle(v.z());
      odometry_cost_ += v.dot(l.W * v);
      if (A) addTerm(oa, Ja, ob, Jb, l.W, v, b);
    }
    for (const ObservationTerm& t : observations_) {
      const int op = 3 * t.scan, om = landmarkOffset(t.landmark);
      Matrix23d Hp;
      Eigen::Matrix2d Hm;
      const Eigen::Vector2d v = RangeBearingModel::innovation(
          t.z, model_.predict(x.segment<3>(op), x.segment<2>(om), t.kind, &Hp, &Hm), t.kind);
      observation_cost_ += v.dot(t.W * v);
      if (A) addTerm(op, Hp, om, Hm, t.W, v, b);
    }
    cost += odometry_cost_ + observation_cost_;
    if (A) {
      A->resize(x.size(), x.size());
      A->setFromTriplets(triplets_.begin(), triplets_.end());
    }
    return cost;
  }

  // The odometry and observation residuals at x with their leverage J N^-1 J^T, the blocks of
  // N^-1 they need taken from `inverse` (N factorised at x).
  template <class Inverse>
  std::vector<SmoothingResidual> residuals(const Eigen::VectorXd& x, const Inverse& inverse) {
    std::vector<SmoothingResidual> out;
    out.reserve(links_.size() + observations_.size());
    Eigen::Matrix3d Ja, Jb;
    for (const PoseTerm& l : links_) {
      SmoothingResidual r;
      r.scan = l.scan;
      const int oa = 3 * (l.scan - 1), ob = 3 * l.scan;
      r.v = l.mean - relativePose(x.segment<3>(oa), x.segment<3>(ob), &Ja, &Jb);
      r.v.z() = wrapAngle(r.v.z());
      r.leverage = leverage<3, 3, 3>(inverse, oa, Ja, ob, Jb);
      out.push_back(r);
    }
    for (const ObservationTerm& t : observations_) {
      SmoothingResidual r;
      r.scan = t.scan;
      r.observation = t.index;
      const int op = 3 * t.scan, om = landmarkOffset(t.landmark);
      Matrix23d Hp;
      Eigen::Matrix2d Hm;
      r.v.head<2>() = RangeBearingModel::innovation(
          t.z, model_.predict(x.segment<3>(op), x.segment<2>(om), t.kind, &Hp, &Hm), t.kind);
      r.leverage.topLeftCorner<2, 2>() = leverage<2, 3, 2>(inverse, op, Hp, om, Hm);
      out.push_back(r);
    }
    return out;
  }

 private:
  // J N^-1 J^T for a residual on the blocks at offsets p (size P) and q (size Q).
  template <int D, int P, int Q, class Inverse>
  static Eigen::Matrix<double, D, D> leverage(const Inverse& inverse, int p,
                                              const Eigen::Matrix<double, D, P>& Jp, int q,
                                              const Eigen::Matrix<double, D, Q>& Jq) {
    Eigen::Matrix<double, P + Q, P + Q> Z;
    const int offset[2] = {p, q}, size[2] = {P, Q};
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int r = 0; r < size[a]; ++r)
          for (int c = 0; c < size[b]; ++c)
            Z(a * P + r, b * P + c) = inverse(offset[a] + r, offset[b] + c);
    Eigen::Matrix<double, D, P + Q> J;
    J << Jp, Jq;
    return J * Z * J.transpose();
  }

  // The normal equations' part of a residual v (weight W) on two blocks at offsets p < q, whose
  // prediction has the Jacobians Jp and Jq.
  template <class Jp_t, class Jq_t, class W_t, class V_t>
  void addTerm(int p, const Jp_t& Jp, int q, const Jq_t& Jq, const W_t& W, const V_t& v,
               Eigen::VectorXd* b) {
    addLower(&triplets_, p, p, Jp, W, Jp);
    addLower(&triplets_, q, q, Jq, W, Jq);
    addLower(&triplets_, q, p, Jq, W, Jp);
    b->segment(p, Jp.cols()) += Jp.transpose() * W * v;
    b->segment(q, Jq.cols()) += Jq.transpose() * W * v;
  }

  const RangeBearingModel& model_;
  int poses_;
  std::vector<int> landmark_input_;  // column -> index in the input landmarks
  std::vector<ObservationTerm> observations_;
  std::vector<PoseTerm> links_, priors_;
  Triplets triplets_;
  std::string error_;
  double odometry_cost_ = 0.0, observation_cost_ = 0.0;
};

void wrapYaws(int poses, Eigen::VectorXd* x) {
  for (int i = 0; i < poses; ++i) (*x)(3 * i + 2) = wrapAngle((*x)(3 * i + 2));
}

}  // namespace

SmoothingResult smoothRun(const std::vector<SmoothingScan>& scans,
                          const std::vector<SmoothingLandmark>& landmarks,
                          const RangeBearingModel& model, const SmootherParams& params) {
  const auto t0 = std::chrono::steady_clock::now();
  SmoothingResult result;
  result.landmarks = landmarks;
  for (const SmoothingScan& s : scans) result.poses.push_back(s.pose);
  Problem problem(scans, landmarks, model, params, &result);
  if (!problem.error().empty()) {
    result.error = problem.error();
    return result;
  }
  const int n = static_cast<int>(scans.size());
  Eigen::VectorXd x(problem.unknowns());
  for (int i = 0; i < n; ++i) x.segment<3>(3 * i) = scans[i].pose;
  const std::vector<int>& cols = problem.landmarkInput();
  for (std::size_t c = 0; c < cols.size(); ++c)
    x.segment<2>(problem.landmarkOffset(static_cast<int>(c))) = landmarks[cols[c]].position;
  if (!x.allFinite()) {
    result.error = "a starting pose or landmark is not finite";
    return result;
  }

  // Gauss-Newton with step halving: the same sparsity in every iteration, so the ordering and
  // the symbolic factorisation are computed once.
  Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::AMDOrdering<int>> solver;
  Sparse A;
  Eigen::VectorXd b;
  double cost = problem.evaluate(x, &A, &b);
  result.initial_cost = cost;
  solver.analyzePattern(A);
  const auto factorise = [&]() {
    solver.factorize(A);
    if (solver.info() != Eigen::Success) {
      result.error = "the normal equations are singular (a pose or landmark nothing constrains?)";
      return false;
    }
    return true;
  };
  for (int it = 0; it < params.max_iterations && !result.converged; ++it) {
    if (!factorise()) return result;
    const Eigen::VectorXd dx = solver.solve(b);
    double step = 1.0, trial_cost = cost;
    Eigen::VectorXd trial;
    for (int halvings = 0; halvings < 10; ++halvings, step *= 0.5) {
      trial = x + step * dx;
      wrapYaws(n, &trial);
      trial_cost = problem.evaluate(trial);
      if (std::isfinite(trial_cost) && trial_cost < cost) break;
    }
    result.iterations = it + 1;
    if (!(std::isfinite(trial_cost) && trial_cost < cost)) {
      result.converged = true;  // no step lowers the cost: at the minimum to rounding
      break;
    }
    result.converged = cost - trial_cost < params.tolerance * cost;
    x = trial;
    cost = problem.evaluate(x, &A, &b);
  }
  result.final_cost = problem.evaluate(x);  // at x (the last evaluation may have been a trial)
  result.odometry_cost_per_residual = problem.odometryCostPerResidual();
  result.observation_cost_per_residual = problem.observationCostPerResidual();

  for (int i = 0; i < n; ++i) result.poses[i] = x.segment<3>(3 * i);
  for (std::size_t c = 0; c < cols.size(); ++c)
    result.landmarks[cols[c]].position = x.segment<2>(problem.landmarkOffset(static_cast<int>(c)));

  const double nan = std::numeric_limits<double>::quiet_NaN();
  result.landmark_covariances.assign(landmarks.size(), Eigen::Matrix2d::Constant(nan));
  // The unknowns' columns of the landmarks asked for (cols[c] is column c's input index).
  std::vector<int> wanted;
  for (std::size_t c = 0; c < cols.size(); ++c)
    if (params.landmark_covariances < 0 || cols[c] < params.landmark_covariances)
      wanted.push_back(static_cast<int>(c));
  if (!wanted.empty() || params.residuals) {
    if (!factorise()) return result;
  }
  if (params.residuals) result.residuals = problem.residuals(x, SelectedInverse(solver));
  if (!wanted.empty()) {
    // Marginals: those columns of A^-1 at the solution, a chunk of columns per solve.
    constexpr int kChunk = 64;
    for (std::size_t c0 = 0; c0 < wanted.size(); c0 += kChunk) {
      const int m = static_cast<int>(std::min<std::size_t>(kChunk, wanted.size() - c0));
      Eigen::MatrixXd E = Eigen::MatrixXd::Zero(x.size(), 2 * m);
      for (int j = 0; j < m; ++j) {
        const int o = problem.landmarkOffset(wanted[c0 + j]);
        E(o, 2 * j) = E(o + 1, 2 * j + 1) = 1.0;
      }
      const Eigen::MatrixXd X = solver.solve(E);
      for (int j = 0; j < m; ++j) {
        const int o = problem.landmarkOffset(wanted[c0 + j]);
        const Eigen::Matrix2d C = X.block<2, 2>(o, 2 * j);
        result.landmark_covariances[cols[wanted[c0 + j]]] = 0.5 * (C + C.transpose());
      }
    }
  }
  result.ok = true;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace ekf_slam
