// The association ceiling of a scan given the true pose and map (evaluation side).
#include "ekf_slam/evaluation/association_ceiling.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "ekf_slam/core/association/hungarian.h"

namespace ekf_slam {
namespace {

double logSumExp(double a, double b) {
  const double m = std::max(a, b);
  return m + std::log(std::exp(a - m) + std::exp(b - m));
}

// Metropolis-Hastings over the one-to-one assignments of the rows of `cost` (M_ij) to distinct
// columns, posterior proportional to prod_i exp(-M_i,a(i) / 2), from `start`. A proposal picks a
// row i and a column j with probability p_i(j) proportional to exp(-M_ij / 2): a free j moves i
// there (accepted always: the proposal is the target's conditional), a j held by row k swaps i
// and k (accepted with the Hastings ratio, as k -> a(i) proposes the same swap). Fills each row's
// most frequent column and its frequency, counted once per sweep after the burn-in.
void posteriorMarginals(const Eigen::MatrixXd& cost, std::vector<int> assign,
                        const CeilingOptions& options, sim::Random* rng, ScanCeiling* out) {
  const int n = static_cast<int>(cost.rows());
  const int m = static_cast<int>(cost.cols());
  Eigen::MatrixXd logp(n, m);
  // Row-major: each row's cumulative distribution is searched as a contiguous array.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cumulative(n, m);
  for (int i = 0; i < n; ++i) {
    const double best = cost.row(i).minCoeff();
    double z = 0.0;
    for (int j = 0; j < m; ++j) z += std::exp(-0.5 * (cost(i, j) - best));
    double sum = 0.0;
    for (int j = 0; j < m; ++j) {
      logp(i, j) = -0.5 * (cost(i, j) - best) - std::log(z);
      sum += std::exp(logp(i, j));
      cumulative(i, j) = sum;
    }
  }
  std::vector<int> owner(m, -1);
  for (int i = 0; i < n; ++i) owner[assign[i]] = i;
  Eigen::MatrixXi counts = Eigen::MatrixXi::Zero(n, m);
  const int sweeps = options.burn_in_sweeps + options.sweeps;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (int step = 0; step < n; ++step) {
      const int i = rng->index(n);
      const double u = rng->uniform() * cumulative(i, m - 1);
      const int j =
          std::min<int>(m - 1, static_cast<int>(std::upper_bound(cumulative.row(i).data(),
                                                                 cumulative.row(i).data() + m, u) -
                                                cumulative.row(i).data()));
      const int a = assign[i];
      if (j == a) continue;
      const int k = owner[j];
      if (k >= 0) {
        const double log_ratio = logp(i, j) + logp(k, a) - logp(i, a) - logp(k, j) +
                                 logSumExp(logp(i, a), logp(k, j)) -
                                 logSumExp(logp(i, j), logp(k, a));
        if (!(std::log(rng->uniform()) < log_ratio)) continue;
        assign[k] = a;
        owner[a] = k;
      } else {
        owner[a] = -1;
      }
      assign[i] = j;
      owner[j] = i;
    }
    if (sweep >= options.burn_in_sweeps) {
      for (int i = 0; i < n; ++i) ++counts(i, assign[i]);
    }
  }
  out->marginal.assign(n, -1);
  out->marginal_probability.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    int best = 0;
    counts.row(i).maxCoeff(&best);
    out->marginal[i] = best;
    out->marginal_probability[i] = static_cast<double>(counts(i, best)) / options.sweeps;
  }
}

}  // namespace

ScanCeiling associationCeiling(const RangeBearingModel& model, const Eigen::Vector3d& pose,
                               const std::vector<Eigen::Vector2d>& landmarks,
                               const std::vector<Observation>& observations,
                               const CeilingOptions& options, sim::Random* rng) {
  const int n = static_cast<int>(observations.size());
  const int m = static_cast<int>(landmarks.size());
  if (n > m) {
    throw std::invalid_argument("associationCeiling: more observations than landmarks");
  }
  if (options.sweeps < 0 || options.burn_in_sweeps < 0) {
    throw std::invalid_argument("associationCeiling: sweeps and burn_in_sweeps must be >= 0");
  }
  if (options.sweeps > 0 && rng == nullptr) {
    throw std::invalid_argument("associationCeiling: the marginals need a random generator");
  }
  ScanCeiling out;
  if (n == 0) return out;
  Eigen::MatrixXd cost(n, m);
  for (int i = 0; i < n; ++i) {
    const Observation& o = observations[i];
    const Eigen::LLT<Eigen::Matrix2d> llt(o.R);
    if (!o.z.allFinite() || llt.info() != Eigen::Success) {
      throw std::invalid_argument("associationCeiling: observation " + std::to_string(i) +
                                  " is not finite or its R is not positive definite");
    }
    for (int j = 0; j < m; ++j) {
      const Eigen::Vector2d v =
          RangeBearingModel::innovation(o.z, model.predict(pose, landmarks[j], o.kind), o.kind);
      cost(i, j) = v.dot(llt.solve(v));
    }
  }
  AssignmentSolver solver;
  solver.solve(cost, &out.joint);
  out.individual.resize(n);
  for (int i = 0; i < n; ++i) cost.row(i).minCoeff(&out.individual[i]);
  if (options.sweeps > 0) posteriorMarginals(cost, out.joint, options, rng, &out);
  return out;
}

}  // namespace ekf_slam
