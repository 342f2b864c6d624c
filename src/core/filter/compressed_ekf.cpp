// Compressed EKF: EKF steps on the active area, global update with phi, psi, theta
// (docs/cekf.md). See compressed_ekf.h.
#include "ekf_slam/core/filter/compressed_ekf.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace ekf_slam {

const char* toString(CekfClosureReason reason) {
  switch (reason) {
    case CekfClosureReason::kGrown:
      return "grown";
    case CekfClosureReason::kLandmarkInReach:
      return "landmark_in_reach";
    case CekfClosureReason::kPairingOutside:
      return "pairing_outside";
    case CekfClosureReason::kFlush:
      return "flush";
  }
  return "?";
}

CompressedEkf::CompressedEkf(EkfSlam* global, const CompressedEkfParams& params)
    : g_(global), p_(params) {}

void CompressedEkf::reset() {
  open_ = compressed_ = false;
  active_.clear();
  rows_dirty_ = true;
}

void CompressedEkf::ensurePhase() {
  if (!open_) openPhase();
}

void CompressedEkf::openPhase(const std::vector<LandmarkId>& extra) {
  const EkfSlam& g = *g_;
  ++stats_.phases;
  open_ = true;
  compressed_ = false;
  active_.clear();
  rows_dirty_ = true;
  vehicle_ = 3 + g.correctionDim();
  // The area is the stretch of area_size ahead of the vehicle (a sensor sees ahead, and a
  // vehicle mostly keeps going): A is every landmark within reach + margin + slack of it.
  opened_ = g.pose();
  centre_ = opened_.head<2>();
  area_updates_ = 0;
  const Eigen::Vector2d ahead(std::cos(g.pose()(2)), std::sin(g.pose()(2)));
  const double h = p_.reach + p_.margin + p_.slack;
  std::vector<int> a, b;  // landmark indices of A and B, global order
  for (std::size_t k = 0; k < g.numLandmarks(); ++k) {
    const int i = static_cast<int>(k);
    const Eigen::Vector2d d = g.landmark(i) - centre_;
    const double t = std::clamp(d.dot(ahead), 0.0, p_.area_size);
    const bool near = (d - t * ahead).norm() <= h;
    const bool named = std::find(extra.begin(), extra.end(), g.landmarkIds()[k]) != extra.end();
    (near || named ? a : b).push_back(i);
  }
  n_a0_ = vehicle_ + 2 * static_cast<int>(a.size());
  // The private filter is twice A's size: compress only when B is at least as large as A.
  if (2 * static_cast<int>(b.size()) < n_a0_) return;
  compressed_ = true;
  ++stats_.compressed_phases;
  stats_.max_active_states = std::max(stats_.max_active_states, std::size_t(n_a0_));

  // Global rows of A0's states; the global filter's lower triangle is current.
  std::vector<int> rows;
  rows.reserve(n_a0_);
  for (int v = 0; v < vehicle_; ++v) rows.push_back(v);
  for (const int k : a) {
    rows.push_back(g.stateRow(k));
    rows.push_back(g.stateRow(k) + 1);
  }
  const ConstMatrixView P = g.storedCovariance();
  const auto at = [&P](int i, int j) { return i >= j ? P(i, j) : P(j, i); };

  // Private state [vehicle, A0, Z]: cov(A0, Z) = I, cov(Z, Z) = 0, x_Z = 0 (one padding
  // phantom when n_a0 is odd: phantoms come in landmark-sized pairs).
  const int nz = n_a0_ + (n_a0_ % 2);
  const int nl = n_a0_ + nz;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(nl, nl);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(nl);
  for (int j = 0; j < n_a0_; ++j) {
    x(j) = g.mean()(rows[j]);
    for (int i = j; i < n_a0_; ++i) C(i, j) = C(j, i) = at(rows[i], rows[j]);
  }
  C.block(n_a0_, 0, n_a0_, n_a0_).setIdentity();
  C.block(0, n_a0_, n_a0_, n_a0_).setIdentity();
  std::vector<LandmarkId> ids;
  ids.reserve(a.size() + nz / 2);
  for (const int k : a) {
    ids.push_back(g.landmarkIds()[k]);
    active_.insert(ids.back());
  }
  for (int k = 0; k < nz / 2; ++k) ids.push_back(kPhantomBase + k);
  local_.k_ = g.k_;
  local_.c_lower_ = g.c_lower_;
  local_.c_upper_ = g.c_upper_;
  local_.setSecondOrderObservations(g_->secondOrderObservations());
  local_.setState(x, C, ids);

  // G = cov(A0, B0), read column by column of the lower triangle where B's row is below.
  b_ids_.clear();
  G_.resize(n_a0_, 2 * static_cast<Eigen::Index>(b.size()));
  for (std::size_t c = 0; c < b.size(); ++c) {
    b_ids_.push_back(g.landmarkIds()[b[c]]);
    const int r = g.stateRow(b[c]);
    for (int t = 0; t < 2; ++t) {
      for (int i = 0; i < n_a0_; ++i) G_(i, 2 * c + t) = at(rows[i], r + t);
    }
  }
}

void CompressedEkf::mapRows() {
  if (!rows_dirty_) return;
  local_rows_.clear();
  global_rows_.clear();
  for (int v = 0; v < vehicle_; ++v) {
    local_rows_.push_back(v);
    global_rows_.push_back(v);
  }
  const std::vector<LandmarkId>& ids = local_.landmarkIds();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (isPhantom(ids[k])) continue;
    const int lr = local_.stateRow(static_cast<int>(k));
    const int gr = g_->stateRow(g_->indexOf(ids[k]));
    for (int t = 0; t < 2; ++t) {
      local_rows_.push_back(lr + t);
      global_rows_.push_back(gr + t);
    }
  }
  rows_dirty_ = false;
}

void CompressedEkf::scatter(bool vehicle_only) {
  mapRows();
  EkfSlam& g = *g_;
  const ConstMatrixView L = local_.storedCovariance();
  MatrixView P = g.P();
  const int m = static_cast<int>(local_rows_.size());
  for (int i = 0; i < m; ++i) g.x_(global_rows_[i]) = local_.x_(local_rows_[i]);
  // Both row lists increase, so i >= j is in the lower triangle of both filters.
  const int cols = vehicle_only ? vehicle_ : m;
  for (int j = 0; j < cols; ++j) {
    const int lj = local_rows_[j], gj = global_rows_[j];
    for (int i = j; i < m; ++i) P(global_rows_[i], gj) = L(local_rows_[i], lj);
  }
  // EkfSlam's other current parts: the vehicle rows and each landmark's 2 x 2 block.
  for (int i = vehicle_; i < m; ++i) {
    for (int v = 0; v < vehicle_; ++v) P(v, global_rows_[i]) = P(global_rows_[i], v);
  }
  if (!vehicle_only) {
    for (int i = vehicle_; i < m; i += 2)
      P(global_rows_[i], global_rows_[i] + 1) = P(global_rows_[i] + 1, global_rows_[i]);
  }
  P.topLeftCorner(vehicle_, vehicle_).triangularView<Eigen::StrictlyUpper>() =
      P.topLeftCorner(vehicle_, vehicle_).transpose();
  g.upper_stale_ = g.dim_ > vehicle_;
}

void CompressedEkf::closePhase(CekfClosureReason reason, const Eigen::Vector2d* trigger) {
  const bool was_compressed = compressed();
  open_ = compressed_ = false;
  const int active_states = vehicle_ + 2 * static_cast<int>(active_.size());
  active_.clear();
  if (!was_compressed) return;
  const auto t0 = std::chrono::steady_clock::now();
  ++stats_.global_updates;
  switch (reason) {
    case CekfClosureReason::kGrown:
      ++stats_.grown;
      break;
    case CekfClosureReason::kLandmarkInReach:
      ++stats_.landmark_in_reach;
      break;
    case CekfClosureReason::kPairingOutside:
      ++stats_.pairing_outside;
      break;
    case CekfClosureReason::kFlush:
      ++stats_.flushes;
      break;
  }
  EkfSlam& g = *g_;
  if (log_ != nullptr) {
    CekfClosure c;
    c.reason = reason;
    c.pose = g.pose();
    c.opened = opened_;
    if (trigger != nullptr) c.trigger = *trigger;
    c.opened_states = n_a0_;
    c.active_states = active_states;
    c.states = static_cast<std::size_t>(g.dim_);
    c.updates = area_updates_;
    log_->push_back(c);
  }
  mapRows();
  rows_dirty_ = true;
  const int m = static_cast<int>(local_rows_.size());
  // Removed landmarks of A0 moved the phantoms up.
  const int z_row = local_.stateRow(local_.indexOf(kPhantomBase));
  const auto L = local_.covariance();  // complete: phi and psi are read across the diagonal
  Eigen::MatrixXd phi(m, n_a0_);
  for (int i = 0; i < m; ++i) phi.row(i) = L.block(local_rows_[i], z_row, 1, n_a0_);
  const Eigen::MatrixXd psi = -L.block(z_row, z_row, n_a0_, n_a0_);
  const Eigen::VectorXd theta = local_.x_.segment(z_row, n_a0_);

  // G with B0's columns where they are now (landmarks of B removed meanwhile: gone), zero in
  // A's columns, so that the products below leave A's entries alone.
  const Eigen::Index n = g.dim_;
  Eigen::MatrixXd Gx = Eigen::MatrixXd::Zero(n_a0_, n);
  std::vector<int> b_rows;
  b_rows.reserve(b_ids_.size());
  for (std::size_t c = 0; c < b_ids_.size(); ++c) {
    const int idx = g.indexOf(b_ids_[c]);
    if (idx < 0) continue;
    b_rows.push_back(g.stateRow(idx));
    Gx.middleCols<2>(b_rows.back()) = G_.middleCols<2>(2 * c);
  }
  MatrixView P = g.P();
  // P_BB -= G^T psi G (lower triangle), x_B += G^T theta.
  const Eigen::MatrixXd M = psi * Gx;
  P.triangularView<Eigen::Lower>() -= Gx.transpose() * M;
  g.x_.noalias() += Gx.transpose() * theta;
  // P_AB = phi G, into the lower triangle and the vehicle rows' upper part.
  const Eigen::MatrixXd C = phi * Gx;
  for (const int r : b_rows) {
    for (int col = r; col < r + 2; ++col) {
      for (int i = 0; i < m; ++i) {
        const int gi = global_rows_[i];
        (gi > col ? P(gi, col) : P(col, gi)) = C(i, col);
      }
      for (int v = 0; v < vehicle_; ++v) P(v, col) = C(v, col);
    }
    P(r, r + 1) = P(r + 1, r);
  }
  g.upper_stale_ = true;
  stats_.global_update_flops +=
      static_cast<double>(n) * n * n_a0_ + 2.0 * static_cast<double>(n_a0_) * (n_a0_ + m) * n;
  stats_.global_update_s +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool CompressedEkf::predict(const MotionStep& step) {
  ensurePhase();
  if (!compressed_) return g_->predict(step);
  if (!local_.predict(step)) return false;
  scatter(/*vehicle_only=*/true);
  return true;
}

bool CompressedEkf::update(const std::vector<Pairing>& pairings, const RangeBearingModel& model,
                           double* nis) {
  ensurePhase();
  if (compressed_) {
    std::vector<LandmarkId> outside;
    for (const Pairing& p : pairings) {
      if (!active_.count(p.id) && g_->contains(p.id)) outside.push_back(p.id);
    }
    if (!outside.empty()) {
      // A landmark of B paired: bring everything up to date and make it part of a new area.
      const Eigen::Vector2d at = g_->landmark(g_->indexOf(outside.front()));
      closePhase(CekfClosureReason::kPairingOutside, &at);
      openPhase(outside);
    }
  }
  if (!compressed_) return g_->update(pairings, model, nis);
  const std::uint64_t clamps = local_.clamps_, refusals = local_.refusals_;
  const bool ok = local_.update(pairings, model, nis);
  ++area_updates_;
  g_->clamps_ += local_.clamps_ - clamps;
  g_->refusals_ += local_.refusals_ - refusals;
  if (ok) scatter(/*vehicle_only=*/false);
  return ok;
}

LandmarkId CompressedEkf::addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                                      const RangeBearingModel& model, MeasurementKind kind) {
  ensurePhase();
  // The global filter computes the new rows from its vehicle rows: current in A's columns (the
  // same numbers as the private filter's), stale in B's, which the global update overwrites.
  const LandmarkId id = g_->addLandmark(z, R, model, kind);
  if (id == kNoLandmark || !compressed_) return id;
  const LandmarkId local = local_.addLandmark(z, R, model, kind);
  if (local == kNoLandmark) {  // cannot happen (same inputs), but never leave them apart
    g_->removeLandmark(id);
    return kNoLandmark;
  }
  local_.ids_.back() = id;  // the private filter uses the global ids
  local_.index_of_.erase(local);
  local_.index_of_[id] = static_cast<int>(local_.ids_.size()) - 1;
  active_.insert(id);
  rows_dirty_ = true;
  return id;
}

bool CompressedEkf::removeLandmark(LandmarkId id) {
  if (!g_->contains(id)) return false;
  // Removing states is marginalising them: it commutes with the other steps. A removed landmark
  // of A keeps its phantom (its row of G still enters the global update).
  if (active(id)) {
    local_.removeLandmark(id);
    active_.erase(id);
  }
  rows_dirty_ = true;
  return g_->removeLandmark(id);
}

bool CompressedEkf::prepare(const LandmarkIndex& index, const Eigen::Vector2d& sensor,
                            double radius) {
  if (!open_) return false;
  if (!compressed_) {
    // Nothing is stale: the choice is made again around the vehicle once it left its area.
    if ((g_->pose().head<2>() - centre_).norm() > 0.5 * p_.area_size) open_ = false;
    return false;
  }
  // New landmarks join A: once it has grown well past its size at the opening, a new area
  // around the vehicle (with the landmarks behind it in B) makes the steps cheaper again. The
  // global update's cost is proportional to A's size at the opening, and so is the time until
  // it has doubled: amortised, it costs N^2 per new landmark state.
  const int active = vehicle_ + 2 * static_cast<int>(active_.size());
  if (active > kGrowth * n_a0_ + kGrowthSlack) {
    closePhase(CekfClosureReason::kGrown);
    return true;
  }
  // Correctness: every landmark the associators may read must be in A.
  near_.clear();
  index.query(*g_, sensor, radius, &near_);
  for (const int k : near_) {
    if (active_.count(g_->landmarkIds()[k])) continue;
    const Eigen::Vector2d at = g_->landmark(k);
    closePhase(CekfClosureReason::kLandmarkInReach, &at);
    return true;
  }
  return false;
}

void CompressedEkf::flush() { closePhase(CekfClosureReason::kFlush); }

}  // namespace ekf_slam
