// RRW&SC graph matching shared by the RRWSC associator and relocaliser; see the header.
#include "ekf_slam/core/graph_matching/rrwsc_matcher.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace ekf_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Variance of the distance between two points along their direction u.
double distanceVariance(const Eigen::Vector2d& u, const Eigen::Matrix2d& a,
                        const Eigen::Matrix2d& b) {
  return u.dot((a + b) * u);
}

}  // namespace

void setObservedPoints(const std::vector<Observation>& observations, MatchInput* in) {
  in->observed.clear();
  in->observed_cov.clear();
  for (const Observation& o : observations) {
    Eigen::Matrix2d g;
    in->observed.push_back(RangeBearingModel::sensorPoint(o.z, o.kind, &g));
    in->observed_cov.push_back(g * o.R * g.transpose());
  }
}

void RrwscParams::read(const ParameterReader& reader, double position_weight_default) {
  context.min_radius = reader.positive("context_min_radius", 2.0);
  context.max_radius = reader.positive("context_max_radius", 100.0);
  if (context.max_radius <= context.min_radius) {
    reader.fail("context_max_radius", "must be > context_min_radius");
  }
  walk.alpha = reader.probability("alpha", 0.2);
  walk.beta = reader.positive("beta", 30.0);
  walk.max_iterations = reader.integer("max_iterations", 300, 1, 100000);
  walk.tolerance = reader.positive("tolerance", 1e-12);
  walk.sinkhorn_iterations = reader.integer("sinkhorn_iterations", 10, 1, 100000);
  walk.sinkhorn_tolerance = reader.positive("sinkhorn_tolerance", 1e-3);
  descriptor_scale = reader.positive("descriptor_scale", 0.2);
  position_weight = reader.nonNegative("position_weight", position_weight_default);
  position_cap = reader.positive("position_cap", 18.420680743952367);
  edge_sigma = reader.positive("edge_sigma", 0.5);
  edge_gate = reader.positive("edge_gate", 3.0);
  edge_neighbours = reader.integer("edge_neighbours", 10, 0, 1000000);
  candidates_per_observation = reader.integer("candidates_per_observation", 8, 1, 1000);
  min_relative_score = reader.inRange("min_relative_score", 1e-3, 0.0, 1.0);
}

void RrwscMatcher::buildCandidates(const MatchInput& in, const RrwscParams& p) {
  const int m = static_cast<int>(in.observed.size());
  const int n = static_cast<int>(in.landmarks.size());
  const bool prior = in.mahalanobis.rows() == m && in.mahalanobis.cols() == n && m > 0;
  contexts_.build(in.observed, p.context, &obs_sc_);
  contexts_.build(in.landmarks, p.context, &map_sc_);
  obs_rings_.resize(m);
  map_rings_.resize(n);
  obs_support_.resize(m);
  map_support_.resize(n);
  for (int i = 0; i < m; ++i) {
    obs_rings_[i] = ringHistogram(obs_sc_[i]);
    obs_support_[i] = shapeContextSupport(obs_sc_[i]);
  }
  for (int j = 0; j < n; ++j) {
    map_rings_[j] = ringHistogram(map_sc_[j]);
    map_support_[j] = shapeContextSupport(map_sc_[j]);
  }
  // The search ranks landmarks by the logarithm of their affinity (no exp per landmark). Its
  // rounding differs from that of the product of two exps, so it only shortlists: whatever lies
  // within kLogMargin of the k-th best, then ranked by the affinity itself (exact top k, ties by
  // index).
  constexpr double kLogMargin = 1e-9;
  const auto log_position = [&](int i, int j) {
    return prior && p.position_weight > 0.0
               ? -0.5 * p.position_weight * std::min(in.mahalanobis(i, j), p.position_cap)
               : 0.0;
  };
  const auto descriptor = [&](int i, int j) {
    return shapeContextDistance(obs_sc_[i], obs_support_[i], map_sc_[j], map_support_[j]);
  };
  const auto affinity = [&](double log_pos, double distance) {
    const double position = prior && p.position_weight > 0.0 ? std::exp(log_pos) : 1.0;
    return position * std::exp(-distance / p.descriptor_scale);
  };
  graph_.clear(m, n);
  cand_begin_.assign(1, 0);
  cand_node_.clear();
  for (int i = 0; i < m; ++i) {
    // Landmarks in index order. Upper bound of a landmark's log affinity: log position factor
    // (0 without a prior) + the ring-histogram term (ringDistance <= shapeContextDistance). Once
    // k candidates beat that bound the landmark cannot enter the top k, so its full shape context
    // need not be compared (the same top k as comparing all).
    const int k = p.candidates_per_observation;
    int nearest = -1;
    best_.clear();      // every landmark compared
    top_keys_.clear();  // min-heap of the k best log affinities so far
    for (int j = 0; j < n; ++j) {
      if (prior) {
        const double mij = in.mahalanobis(i, j);
        if (!(mij < kInf)) continue;
        if (nearest < 0 || mij < in.mahalanobis(i, nearest)) nearest = j;
      }
      const double log_pos = log_position(i, j);
      if (static_cast<int>(top_keys_.size()) == k &&
          log_pos - ringDistance(obs_rings_[i], map_rings_[j]) / p.descriptor_scale <
              top_keys_.front() - kLogMargin) {
        continue;
      }
      const double distance = descriptor(i, j);
      const double key = log_pos - distance / p.descriptor_scale;
      best_.push_back({key, log_pos, distance, 0.0, j});
      if (static_cast<int>(top_keys_.size()) < k) {
        top_keys_.push_back(key);
        std::push_heap(top_keys_.begin(), top_keys_.end(), std::greater<>());
      } else if (key > top_keys_.front()) {
        std::pop_heap(top_keys_.begin(), top_keys_.end(), std::greater<>());
        top_keys_.back() = key;
        std::push_heap(top_keys_.begin(), top_keys_.end(), std::greater<>());
      }
    }
    const double shortlist =
        static_cast<int>(top_keys_.size()) == k ? top_keys_.front() - kLogMargin : -kInf;
    best_.erase(std::remove_if(best_.begin(), best_.end(),
                               [&](const Ranked& r) { return r.log_node < shortlist; }),
                best_.end());
    for (Ranked& r : best_) r.node = affinity(r.log_position, r.distance);
    std::sort(best_.begin(), best_.end(), [](const Ranked& a, const Ranked& b) {
      return a.node > b.node || (a.node == b.node && a.landmark < b.landmark);
    });
    best_.resize(std::min<int>(k, static_cast<int>(best_.size())));
    bool has_nearest = nearest < 0;
    for (const Ranked& r : best_) {
      graph_.addCandidate(i, r.landmark);
      cand_node_.push_back(r.node);
      has_nearest = has_nearest || r.landmark == nearest;
    }
    // The prior's own best guess always takes part, however its descriptor scores.
    if (!has_nearest) {
      graph_.addCandidate(i, nearest);
      cand_node_.push_back(affinity(log_position(i, nearest), descriptor(i, nearest)));
    }
    cand_begin_.push_back(graph_.size());
  }
}

void RrwscMatcher::buildAffinity(const MatchInput& in, const RrwscParams& p) {
  const int m = static_cast<int>(in.observed.size());
  const int n = static_cast<int>(in.landmarks.size());
  const int n_cand = graph_.size();
  const double floor_var = p.edge_sigma * p.edge_sigma;
  const double gate2 = p.edge_gate * p.edge_gate;
  // Pairwise distances and their variances along the pair's direction, once per pair of
  // observations and per pair of landmarks that take part (the candidate loop visits each many
  // times).
  obs_dist_.setZero(m, m);
  obs_var_.setZero(m, m);
  for (int i = 0; i < m; ++i) {
    for (int k = i + 1; k < m; ++k) {
      const Eigen::Vector2d d = in.observed[k] - in.observed[i];
      const double r = d.norm();
      const Eigen::Vector2d u = r > 0.0 ? Eigen::Vector2d(d / r) : Eigen::Vector2d(1, 0);
      obs_dist_(i, k) = obs_dist_(k, i) = r;
      obs_var_(i, k) = obs_var_(k, i) =
          distanceVariance(u, in.observed_cov[i], in.observed_cov[k]) + floor_var;
    }
  }
  // Edges only between observations that are among each other's edge_neighbours nearest
  // (symmetrised): near pairs carry the most precise distances, and the affinity stays
  // O(m x edge_neighbours x k^2) instead of O((m k)^2).
  linked_.assign(static_cast<std::size_t>(m) * m, p.edge_neighbours <= 0 ? 1 : 0);
  if (p.edge_neighbours > 0) {
    for (int i = 0; i < m; ++i) {
      near_.clear();
      for (int k = 0; k < m; ++k) {
        if (k != i) near_.emplace_back(obs_dist_(i, k), k);
      }
      const int keep = std::min<int>(p.edge_neighbours, static_cast<int>(near_.size()));
      std::nth_element(near_.begin(), near_.begin() + keep, near_.end());  // the set suffices
      for (int q = 0; q < keep; ++q) {
        linked_[static_cast<std::size_t>(i) * m + near_[q].second] = 1;
        linked_[static_cast<std::size_t>(near_[q].second) * m + i] = 1;
      }
    }
  }
  used_.clear();
  local_of_.assign(n, -1);
  for (int c = 0; c < n_cand; ++c) {
    if (local_of_[graph_.col[c]] < 0) {
      local_of_[graph_.col[c]] = static_cast<int>(used_.size());
      used_.push_back(graph_.col[c]);
    }
  }
  const int u_n = static_cast<int>(used_.size());
  map_dist_.resize(u_n, u_n);
  map_var_.resize(u_n, u_n);
  for (int a = 0; a < u_n; ++a) {
    for (int b = a + 1; b < u_n; ++b) {
      const Eigen::Vector2d d = in.landmarks[used_[b]] - in.landmarks[used_[a]];
      const double r = d.norm();
      const Eigen::Vector2d u = r > 0.0 ? Eigen::Vector2d(d / r) : Eigen::Vector2d(1, 0);
      map_dist_(a, b) = map_dist_(b, a) = r;
      map_var_(a, b) = map_var_(b, a) =
          distanceVariance(u, in.landmark_cov[used_[a]], in.landmark_cov[used_[b]]);
    }
  }
  // An edge's affinity is weighted by its two correspondences' node affinities (geometric
  // mean): at high noise the distances agree with everything and the nodes decide, at low noise
  // the distances separate what the nodes cannot.
  node_root_.resize(n_cand);
  for (int c = 0; c < n_cand; ++c) node_root_[c] = std::sqrt(cand_node_[c]);
  // K is symmetric: each pair of candidates of linked observations is checked once (c < d:
  // candidates are numbered by observation), and its two entries differ only in the order of the
  // node factors.
  cand_local_.resize(n_cand);
  for (int c = 0; c < n_cand; ++c) cand_local_[c] = local_of_[graph_.col[c]];
  edges_.clear();
  for (int c = 0; c < n_cand; ++c) {
    const int i = graph_.row[c];
    const int a = cand_local_[c];
    // Column a of the (symmetric) landmark matrices: the entries (a, b) in sequence.
    const double* dist_a = map_dist_.data() + static_cast<std::size_t>(a) * u_n;
    const double* var_a = map_var_.data() + static_cast<std::size_t>(a) * u_n;
    for (int k = i + 1; k < m; ++k) {
      if (!linked_[static_cast<std::size_t>(i) * m + k]) continue;
      const double d_obs = obs_dist_(i, k);
      const double var_obs = obs_var_(i, k);
      for (int d = cand_begin_[k]; d < cand_begin_[k + 1]; ++d) {
        const int b = cand_local_[d];
        if (b == a) continue;  // one landmark for two observations: conflicting
        const double var = var_obs + var_a[b];
        const double e = d_obs - dist_a[b];
        if (e * e > gate2 * var) continue;
        edges_.push_back({c, d, std::exp(-0.5 * e * e / var)});
      }
    }
  }
  // Compressed rows: the diagonal, then the columns in ascending order (the pairs come ordered
  // by c then d, so row d receives its columns c < d in order before its own c > d).
  graph_.start.assign(n_cand + 1, 0);
  for (const Edge& edge : edges_) {
    ++graph_.start[edge.c + 1];
    ++graph_.start[edge.d + 1];
  }
  for (int c = 0; c < n_cand; ++c) graph_.start[c + 1] += graph_.start[c] + 1;
  graph_.index.resize(graph_.start[n_cand]);
  graph_.value.resize(graph_.start[n_cand]);
  fill_.assign(graph_.start.begin(), graph_.start.end() - 1);
  const auto put = [&](int row, int col, double v) {
    graph_.index[fill_[row]] = col;
    graph_.value[fill_[row]++] = v;
  };
  for (int c = 0; c < n_cand; ++c) put(c, c, cand_node_[c]);
  for (const Edge& edge : edges_) {
    put(edge.c, edge.d, edge.affinity * node_root_[edge.c] * node_root_[edge.d]);
    put(edge.d, edge.c, edge.affinity * node_root_[edge.d] * node_root_[edge.c]);
  }
}

void RrwscMatcher::match(const MatchInput& in, const RrwscParams& p,
                         std::vector<int>* landmark_of_obs) {
  p_ = p;
  buildCandidates(in, p);
  buildAffinity(in, p);
  stats_.candidates = graph_.size();
  stats_.entries = graph_.entries();
  stats_.iterations = walk_.run(graph_, p.walk, &x_);
  discretise(nullptr, landmark_of_obs);
}

void RrwscMatcher::discretise(const std::vector<char>* forbidden,
                              std::vector<int>* landmark_of_obs) {
  const int m = graph_.rows;
  landmark_of_obs->assign(m, -1);
  const int n_cand = graph_.size();
  if (n_cand == 0) return;
  const double top = x_.maxCoeff();
  if (!(top > 0.0)) return;
  // Rows: observations with a candidate; columns: their landmarks, then one "unmatched" column
  // per row (cost 1 - min_relative_score, so a match must score above that share of the best).
  obs_of_row_.clear();
  col_of_landmark_.assign(graph_.cols, -1);
  landmark_of_col_.clear();
  for (int i = 0; i < m; ++i) {
    if (cand_begin_[i] == cand_begin_[i + 1]) continue;
    obs_of_row_.push_back(i);
    for (int c = cand_begin_[i]; c < cand_begin_[i + 1]; ++c) {
      if (col_of_landmark_[graph_.col[c]] < 0) {
        col_of_landmark_[graph_.col[c]] = static_cast<int>(landmark_of_col_.size());
        landmark_of_col_.push_back(graph_.col[c]);
      }
    }
  }
  const int rows = static_cast<int>(obs_of_row_.size());
  const int cols = static_cast<int>(landmark_of_col_.size());
  cost_.setConstant(rows, cols + rows, kInf);
  for (int r = 0; r < rows; ++r) {
    const int i = obs_of_row_[r];
    for (int c = cand_begin_[i]; c < cand_begin_[i + 1]; ++c) {
      if (forbidden != nullptr && (*forbidden)[c]) continue;
      cost_(r, col_of_landmark_[graph_.col[c]]) = 1.0 - x_[c] / top;
    }
    cost_(r, cols + r) = 1.0 - p_.min_relative_score;
  }
  solver_.solve(cost_, &row_to_col_);
  for (int r = 0; r < rows; ++r) {
    const int col = row_to_col_[r];
    if (col >= 0 && col < cols) (*landmark_of_obs)[obs_of_row_[r]] = landmark_of_col_[col];
  }
}

}  // namespace ekf_slam
