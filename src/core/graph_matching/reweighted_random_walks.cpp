// Reweighted random walks (Cho, Lee & Lee 2010) on a sparse affinity; see the header.
#include "ekf_slam/core/graph_matching/reweighted_random_walks.h"

#include <algorithm>
#include <cmath>

namespace ekf_slam {

void MatchGraph::clear(int rows_, int cols_) {
  rows = rows_;
  cols = cols_;
  row.clear();
  col.clear();
  start.clear();
  index.clear();
  value.clear();
}

int MatchGraph::addCandidate(int r, int c) {
  row.push_back(r);
  col.push_back(c);
  return static_cast<int>(row.size()) - 1;
}

void ReweightedRandomWalks::normaliseDummies(double dummies) {
  double total = 0.0;
  for (double s : slack_) total += s;
  if (dummies > 0.0 && total > 0.0) {
    for (double& s : slack_) s *= dummies / total;
  }
}

void ReweightedRandomWalks::sinkhorn(const MatchGraph& g, const RrwParams& p, Eigen::VectorXd* a) {
  const int n = g.size();
  // The smaller side is padded with |rows - cols| dummy nodes of ones. The dummies stay equal to
  // each other under the normalisation, so their entries aggregate to one slack value per node
  // of the other side, whose total is the number of dummies.
  const bool pad_rows = g.rows < g.cols;  // dummy rows: slack per column
  const int other = pad_rows ? g.cols : g.rows;
  const double dummies = std::abs(g.rows - g.cols);
  slack_.assign(other, dummies);
  row_sum_.assign(g.rows, 0.0);
  col_sum_.resize(g.cols);
  // Each pass over the candidates normalises one side and sums the other (the same sums, in the
  // same order, as a pass of their own).
  for (int c = 0; c < n; ++c) row_sum_[g.row[c]] += (*a)[c];
  for (int it = 0; it < p.sinkhorn_iterations; ++it) {
    // Rows.
    if (!pad_rows) {
      for (int r = 0; r < g.rows; ++r) row_sum_[r] += slack_[r];
      for (int r = 0; r < g.rows; ++r) {
        if (row_sum_[r] > 0.0) slack_[r] /= row_sum_[r];
      }
    }
    std::fill(col_sum_.begin(), col_sum_.end(), 0.0);
    for (int c = 0; c < n; ++c) {
      if (row_sum_[g.row[c]] > 0.0) (*a)[c] /= row_sum_[g.row[c]];
      col_sum_[g.col[c]] += (*a)[c];
    }
    if (pad_rows) normaliseDummies(dummies);  // the dummy rows sum to one each
    // Columns.
    if (pad_rows) {
      for (int s = 0; s < g.cols; ++s) col_sum_[s] += slack_[s];
      for (int s = 0; s < g.cols; ++s) {
        if (col_sum_[s] > 0.0) slack_[s] /= col_sum_[s];
      }
    }
    std::fill(row_sum_.begin(), row_sum_.end(), 0.0);
    for (int c = 0; c < n; ++c) {
      if (col_sum_[g.col[c]] > 0.0) (*a)[c] /= col_sum_[g.col[c]];
      row_sum_[g.row[c]] += (*a)[c];
    }
    if (!pad_rows) normaliseDummies(dummies);  // the dummy columns sum to one each
    // Converged when the rows (normalised before the column step) still sum to one.
    double worst = 0.0;
    for (int r = 0; r < g.rows; ++r) {
      const double total = row_sum_[r] + (pad_rows ? 0.0 : slack_[r]);
      if (total > 0.0) worst = std::max(worst, std::abs(total - 1.0));
    }
    if (worst < p.sinkhorn_tolerance) break;
  }
}

int ReweightedRandomWalks::run(const MatchGraph& g, const RrwParams& p, Eigen::VectorXd* x) {
  const int n = g.size();
  x->setConstant(n, n > 0 ? 1.0 / n : 0.0);
  if (n == 0) return 0;
  double d_max = 0.0;
  for (int c = 0; c < n; ++c) {
    double d = 0.0;
    for (int k = g.start[c]; k < g.start[c + 1]; ++k) d += g.value[k];
    d_max = std::max(d_max, d);
  }
  if (!(d_max > 0.0)) return 0;
  prev_ = *x;
  prev2_ = *x;
  assign_ = *x;
  cur_.resize(n);
  int it = 0;
  while (it < p.max_iterations) {
    ++it;
    mixed_ = p.alpha * prev_ + (1.0 - p.alpha) * assign_;
    for (int c = 0; c < n; ++c) {
      double s = 0.0;
      for (int k = g.start[c]; k < g.start[c + 1]; ++k) s += g.value[k] * mixed_[g.index[k]];
      cur_[c] = s / d_max;
    }
    const double sum = cur_.sum();
    if (sum > 0.0) cur_ /= sum;
    const double top = cur_.maxCoeff();
    if (top > 0.0) {
      for (int c = 0; c < n; ++c) assign_[c] = std::exp(p.beta * cur_[c] / top);
      sinkhorn(g, p, &assign_);
      const double total = assign_.sum();
      if (total > 0.0) assign_ /= total;
    }
    const double change = std::min((cur_ - prev_).squaredNorm(), (cur_ - prev2_).squaredNorm());
    prev2_ = prev_;
    prev_ = cur_;
    if (change < p.tolerance) break;
  }
  *x = cur_;
  return it;
}

}  // namespace ekf_slam
