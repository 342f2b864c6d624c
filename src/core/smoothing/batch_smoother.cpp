#include "ekf_slam/core/smoothing/batch_smoother.h"

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
      for (const SmoothingObservation& o : scans[i].observations) {
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
        observations_.push_back({static_cast<int>(i), col, o.z, W, o.kind});
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

 private:
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
  if (!wanted.empty()) {
    // Marginals: those columns of A^-1 at the solution, a chunk of columns per solve.
    if (!factorise()) return result;
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
