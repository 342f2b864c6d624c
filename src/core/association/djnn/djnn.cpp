// Dynamic Joint Nearest Neighbour (seed 000 section 3). See djnn.h and docs/djnn.md.
#include "ekf_slam/core/association/djnn/djnn.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxEvidence = 1000000;
// Fractional evidence steps (P_D < 1) accumulate rounding: thresholds are compared with this
// slack. Steps of exactly +-1 (P_D = 1, no clutter) keep T an exact integer, so it changes nothing.
constexpr double kEvidenceEps = 1e-9;
// Tentative slots checked per scan for the timeout, wherever they are (amortised clean-up of
// features the robot never comes back to).
constexpr std::size_t kSweepPerScan = 8;

// v - v_bar in measurement space, a bearing wrapped. v_bar is a mean over the scan's pairs, so a
// scan is expected to hold one measurement kind (one sensor).
inline Eigen::Vector2d compensate(const Eigen::Vector2d& v, const Eigen::Vector2d& v_bar,
                                  MeasurementKind kind) {
  if (kind == MeasurementKind::kCartesian) return v - v_bar;
  return Eigen::Vector2d(v(0) - v_bar(0), wrapAngle(v(1) - v_bar(1)));
}

inline std::int64_t cellOf(double v, double cell) {
  const double c = std::floor(v / cell);
  if (!(c > -1.0e9)) return -1000000000LL;
  if (c > 1.0e9) return 1000000000LL;
  return static_cast<std::int64_t>(c);
}

inline std::int64_t packCell(std::int64_t ix, std::int64_t iy) {
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

// -2 ln of "a landmark not in the map, or clutter" per observation: the density of unmapped
// landmarks plus the clutter density (per m^2), the null hypothesis of the density test and of
// the joint decision.
// Keys of live tentative features in the joint decision (remembered features count from 0).
constexpr int kLiveKeyBase = 1 << 28;
// DJNN::force_new_ values: admitted on a remembered feature; held by the joint decision.
constexpr char kAdmit = 1;
constexpr char kHeld = 2;
// With held scans in the window, the current scan's alternatives are searched up to this many
// joint margins from its best (docs/djnn.md, "Deciding a held closure on the held scans").
constexpr double kWindowSearch = 3.0;

double unmappedCost(const DJNN::Params& p) {
  return -2.0 * std::log(p.landmark_density + p.sensor.clutter_density);
}

}  // namespace

DJNN::DJNN() {
  // Usable without configure() (tests, tools): the documented defaults.
  configure(MapParameterSource());
}

void DJNN::configure(const ParameterSource& params) {
  const ParameterReader r(params);
  const Params def;  // the documented defaults
  Params p;
  p.sensor = readSensorModel(r, def.sensor);
  p.range_margin = r.nonNegative("range_margin", def.range_margin);
  if (p.range_margin >= p.sensor.max_range) {
    r.fail("range_margin", "must be smaller than sensor_range (eq. 7 shrinks R by it)");
  }
  p.angle_margin = r.inRange("angle_margin", def.angle_margin, 0.0, M_PI / 2);
  p.individual_probability = r.probability("individual_probability", def.individual_probability);
  p.ambiguity_probability = r.probability("ambiguity_probability", def.ambiguity_probability);
  if (p.ambiguity_probability < p.individual_probability) {
    r.fail("ambiguity_probability", "must be at least individual_probability");
  }
  p.wide_gate_factor = r.inRange("wide_gate_factor", def.wide_gate_factor, 1.0, 1.0e6);
  p.admit_evidence = r.integer("admit_evidence", def.admit_evidence, 1, kMaxEvidence);
  p.remove_evidence =
      r.integer("remove_evidence", def.remove_evidence, -kMaxEvidence, p.admit_evidence - 1);
  p.initial_evidence =
      r.integer("initial_evidence", def.initial_evidence, p.remove_evidence + 1, kMaxEvidence);
  p.max_evidence = r.integer("max_evidence", def.max_evidence, 0, kMaxEvidence);
  if (p.max_evidence != 0 && p.max_evidence < std::max(p.admit_evidence, p.initial_evidence)) {
    r.fail("max_evidence", "must be 0 (unbounded) or at least admit_evidence and initial_evidence");
  }
  p.tentative_gate_probability =
      r.probability("tentative_gate_probability", def.tentative_gate_probability);
  p.tentative_timeout = r.nonNegative("tentative_timeout", def.tentative_timeout);
  p.penalty_region = r.text("penalty_region", def.penalty_region, {"sensor", "valid"});
  p.static_test = r.flag("static_test", def.static_test);
  p.static_probability = r.probability("static_probability", def.static_probability);
  p.static_jitter = r.nonNegative("static_jitter", def.static_jitter);
  p.static_heading = r.flag("static_heading", def.static_heading);
  p.tentative_follow_pose = r.flag("tentative_follow_pose", def.tentative_follow_pose);
  p.shift_test = r.flag("shift_test", def.shift_test);
  p.shift_margin = r.nonNegative("shift_margin", def.shift_margin);
  p.landmark_density = r.nonNegative("landmark_density", def.landmark_density);
  p.loop_closure_age = r.nonNegative("loop_closure_age", def.loop_closure_age);
  p.joint_margin = r.nonNegative("joint_margin", def.joint_margin);
  p.remembered_sightings =
      r.integer("remembered_sightings", def.remembered_sightings, 0, kMaxEvidence);
  p.held_birth_cost = r.nonNegative("held_birth_cost", def.held_birth_cost);
  p.landmark_spacing = r.nonNegative("landmark_spacing", def.landmark_spacing);
  p.coverage_cell = r.nonNegative("coverage_cell", def.coverage_cell);
  p.coverage_max_looks = r.integer("coverage_max_looks", def.coverage_max_looks, 0, 65535);
  if (p.coverage_cell > 0.0 && (p.sensor.clutter_density <= 0.0 || p.loop_closure_age <= 0.0)) {
    r.fail("coverage_cell", "needs clutter_density > 0 and loop_closure_age > 0");
  }
  if (p.landmark_spacing > 0.0 && p.sensor.clutter_density <= 0.0) {
    r.fail("landmark_spacing", "needs clutter_density > 0 (the only \"not in the map\" it leaves)");
  }
  p.held_window_scans = r.integer("held_window_scans", def.held_window_scans, 0, 1000);
  p.held_window_margin = r.nonNegative("held_window_margin", def.held_window_margin);
  p.held_confirmations = r.integer("held_confirmations", def.held_confirmations, 0, 100);
  if (p.loop_closure_age > 0.0 && p.landmark_density + p.sensor.clutter_density <= 0.0) {
    r.fail(
        "loop_closure_age",
        "needs landmark_density or clutter_density > 0 (the joint decision's \"not in the map\")");
  }
  p.static_min_speed = r.nonNegative("static_min_speed", def.static_min_speed);
  p.bias_test = r.flag("bias_test", def.bias_test);
  p.bias_probability = r.probability("bias_probability", def.bias_probability);
  p.bias_window = r.inRange("bias_window", def.bias_window, 1.0, 1.0e6);
  p.bias_min_pairings = r.integer("bias_min_pairings", def.bias_min_pairings, 1, kMaxEvidence);
  p.bias_keep_pairings = r.integer("bias_keep_pairings", def.bias_keep_pairings, 0, kMaxEvidence);

  p_ = p;
  held_window_ = HeldWindow(p_.held_window_scans);
  gate_ = chi2Quantile(p_.individual_probability, 2);
  wide_gate_ = p_.wide_gate_factor * gate_;
  ambiguity_gate_ = chi2Quantile(p_.ambiguity_probability, 2);
  tentative_gate_ = chi2Quantile(p_.tentative_gate_probability, 2);
  static_gate_ = Chi2Table(p_.static_probability, 2 * std::max(p_.admit_evidence, 2));
  velocity_gate_ = chi2Quantile(p_.static_probability, 2);
  baseline_information_ = 0.0;
  if (p_.static_min_speed > 0.0) {
    // An object at speed v has v_hat ~ N(v, J^-1): it fails the velocity test with probability
    // about p when v sqrt(lambda_min(J)) >= sqrt(chi2(2, p)) + z_p (z_p: the standard normal
    // quantile, one-sided along its direction of motion).
    const double q = p_.static_probability;
    const double z = q >= 0.5 ? std::sqrt(chi2Quantile(2.0 * q - 1.0, 1))
                              : -std::sqrt(chi2Quantile(1.0 - 2.0 * q, 1));
    const double k = std::max(0.0, std::sqrt(velocity_gate_) + z) / p_.static_min_speed;
    baseline_information_ = k * k;
  }
  bias_gate_ = chi2Quantile(p_.bias_probability, 2);
  bias_decay_ = 1.0 - 1.0 / p_.bias_window;
  tentative_cell_ = 0.5 * (p_.sensor.max_range + p_.range_margin);
  coverage_ = CoverageGrid(p_.coverage_cell > 0.0 ? p_.coverage_cell : 1.0);
  miss_table_.assign(1, 1.0);
  for (int n = 1; n <= p_.coverage_max_looks; ++n) {
    miss_table_.push_back(miss_table_.back() * (1.0 - p_.sensor.detection_probability));
  }
  if (p_.penalty_region == "valid") {
    penalty_radial_ = -p_.range_margin;
    penalty_lateral_ = -(p_.angle_margin * p_.sensor.max_range);
  } else {
    penalty_radial_ = 0.0;
    penalty_lateral_ = 0.0;
  }
  reset();
}

void DJNN::reset() {
  evidence_.clear();
  last_paired_.clear();
  stamp_ = 0.0;
  bias_.clear();
  tentative_.clear();
  free_slots_.clear();
  tentative_cells_.clear();
  tentative_sweep_ = 0;
  pending_new_.clear();
  remembered_.clear();
  remembered_keys_ = 0;
  coverage_.clear();
  force_new_.clear();
  held_window_.clear();
  held_leads_.clear();
  held_streak_ = 0;
  last_case_ = Case::kNone;
  last_v_bar_.setZero();
  stats_ = Stats();
}

// --- regions (eq. 7, 10) -------------------------------------------------------------------------

// Eq. 7 / 10 are written for a 180 deg sensor: the half-plane x_s > margin. SensorModel::contains
// generalises them: for a wedge of 2a the signed distance to the nearer edge ray,
// sin(a) x - cos(a) |y|, must exceed the margin (exactly x_s at a = 90 deg); a polygon adds the
// distance to each of its edges; a minimum range is grown / shrunk like the maximum range.

void DJNN::buildCandidates(const AssociationContext& ctx) {
  const double R = p_.sensor.max_range;
  const Eigen::Vector2d origin = sensor_pose_.head<2>();
  const double c = std::cos(sensor_pose_(2));
  const double s = std::sin(sensor_pose_(2));
  // Spatial index first (O(cells + nearby)), then the exact eq. 10.
  near_ = ctx.landmarksNear(origin, R + p_.range_margin);
  std::sort(near_.begin(), near_.end());  // deterministic order, whatever the index returns
  cand_.clear();
  cand_valid_.clear();
  const EkfSlam& ekf = ctx.ekf();
  for (int j : near_) {
    const Eigen::Vector2d d = ekf.landmark(j) - origin;
    const Eigen::Vector2d ps(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
    if (!inRegion(ps, p_.range_margin, p_.angle_margin * R)) continue;  // eq. 10
    cand_.push_back(j);
    cand_valid_.push_back(inRegion(ps, -p_.range_margin, -(p_.angle_margin * R)));  // eq. 7
  }
}

// --- association -------------------------------------------------------------------------------

double DJNN::score(int obs, int cand, const Eigen::Vector2d& v_bar, double* mahalanobis) const {
  const AssociationContext::Individual& ind = pair(obs, cand);
  const Eigen::Vector2d v = compensate(ind.v, v_bar, obs_kind_[obs]);
  const double m = v.dot(ind.S_inv * v);
  *mahalanobis = m;
  return m + ind.log_det_S;  // eq. 5
}

int DJNN::nearest(int obs, const Eigen::Vector2d& v_bar, bool use_taken) const {
  int best = -1;
  double best_score = kInf;
  for (int c = 0; c < static_cast<int>(cand_.size()); ++c) {
    if (use_taken && taken_[c]) continue;
    double m;
    const double sc = score(obs, c, v_bar, &m);
    if (m <= gate_ && sc < best_score) {  // eq. 4, then eq. 5
      best_score = sc;
      best = c;
    }
  }
  return best;
}

void DJNN::nearestAll(const Eigen::Vector2d& v_bar) {
  for (int i = 0; i < static_cast<int>(assign_.size()); ++i) assign_[i] = nearest(i, v_bar, false);
}

int DJNN::countPairings() {
  count_.assign(cand_.size(), 0);
  for (int a : assign_) {
    if (a >= 0) ++count_[a];
  }
  int contested = 0;
  for (int n : count_) contested += n >= 2;
  return contested;
}

Eigen::Vector2d DJNN::meanInnovationOfUnique() const {
  // Eq. 6 over the pairs whose landmark no other observation claims.
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int p = 0;
  for (int i = 0; i < static_cast<int>(assign_.size()); ++i) {
    const int a = assign_[i];
    if (a < 0 || count_[a] != 1) continue;
    sum += pair(i, a).v;
    ++p;
  }
  return p > 0 ? Eigen::Vector2d(sum / p) : Eigen::Vector2d::Zero();
}

void DJNN::resolve(const Eigen::Vector2d& v_bar) {
  const int n = static_cast<int>(cand_.size());
  const int m = static_cast<int>(assign_.size());
  std::vector<int>& winner = winner_;
  std::vector<double>& winner_score = winner_score_;
  // Every round hands each contested landmark to one observation and marks it taken; losers only
  // go to untaken landmarks, so the taken set grows every round: at most n rounds.
  for (int round = 0; round <= n; ++round) {
    if (countPairings() == 0) return;
    ++stats_.resolution_rounds;
    winner.assign(n, -1);
    winner_score.assign(n, kInf);
    for (int i = 0; i < m; ++i) {
      const int a = assign_[i];
      if (a < 0 || count_[a] < 2) continue;
      double mah;
      const double sc = score(i, a, v_bar, &mah);
      if (sc < winner_score[a]) {
        winner_score[a] = sc;
        winner[a] = i;
      }
    }
    for (int c = 0; c < n; ++c) taken_[c] = count_[c] > 0;
    for (int i = 0; i < m; ++i) {
      const int a = assign_[i];
      if (a < 0 || count_[a] < 2 || winner[a] == i) continue;
      assign_[i] = nearest(i, v_bar, true);
    }
  }
  countPairings();
}

AssociationResult DJNN::associate(const AssociationContext& ctx) {
  const int m = static_cast<int>(ctx.numObservations());
  AssociationResult result;
  result.resize(m);
  pending_new_.assign(m, -1);
  force_new_.assign(m, 0);
  held_scan_ = false;
  last_v_bar_.setZero();
  if (m == 0) {
    // The paper calls DJNN only for non-empty scans (seed 000 section 5.2: 6949 non-empty scans,
    // 6948 calls), so an empty scan changes no counter.
    last_case_ = Case::kNone;
    return result;
  }
  ++stats_.scans;
  stamp_ = ctx.stamp();
  sensor_pose_ = ctx.sensorPose();
  if (p_.held_window_scans > 0) held_window_.advance(ctx.robotPose(), ctx.ekf().poseCovariance());
  obs_kind_.resize(m);
  for (int i = 0; i < m; ++i) obs_kind_[i] = ctx.observations()[i].kind;
  buildCandidates(ctx);
  const int n = static_cast<int>(cand_.size());

  // Plain NN on the local region (eq. 4-5).
  assign_.assign(m, -1);
  gated_.assign(m, 0);
  for (int i = 0; i < m; ++i) {
    const int j = nearestNeighbour(ctx, i, cand_, gate_);
    if (j < 0) continue;
    assign_[i] = static_cast<int>(std::lower_bound(cand_.begin(), cand_.end(), j) - cand_.begin());
    gated_[i] = 1;
  }
  const int contested = countPairings();
  int paired = 0, unique = 0;
  for (int a : assign_) {
    if (a < 0) continue;
    ++paired;
    unique += count_[a] == 1;
  }

  const bool any_valid = std::find(cand_valid_.begin(), cand_valid_.end(), 1) != cand_valid_.end();
  bool have_table = false;
  if (paired > 0 && contested == 0) {
    last_case_ = Case::kNoInterference;  // case 1
  } else if (paired == 0 && !any_valid) {
    last_case_ = Case::kNothingPaired;  // case 4, nothing should have been seen (eq. 7): accept
    ++stats_.case4_accepted;
  } else {
    // Cases 2-4 need every pair, compensated: compute them once.
    have_table = true;
    table_.resize(static_cast<std::size_t>(m) * n);
    for (int i = 0; i < m; ++i) {
      for (int c = 0; c < n; ++c) {
        table_[static_cast<std::size_t>(i) * n + c] = ctx.individual(i, cand_[c]);
      }
    }
    taken_.assign(n, 0);
    Eigen::Vector2d v_bar = Eigen::Vector2d::Zero();
    if (paired == 0) {
      last_case_ = Case::kNothingPaired;  // case 4
      // Any landmark that should have been seen (eq. 7)? Then the closest pair within the wide
      // gate (eq. 8) measures the jump of the estimate.
      int bi = -1, bc = -1;
      double best = kInf;
      for (int c = 0; c < n; ++c) {
        if (!cand_valid_[c]) continue;
        for (int i = 0; i < m; ++i) {
          const double mah = pair(i, c).mahalanobis;
          if (mah <= wide_gate_ && mah < best) {
            best = mah;
            bi = i;
            bc = c;
          }
        }
      }
      if (bi < 0) {
        ++stats_.case4_accepted;
      } else {
        ++stats_.case4_compensated;
        v_bar = pair(bi, bc).v;
        nearestAll(v_bar);
        resolve(v_bar);
      }
    } else if (unique > 0) {
      last_case_ = Case::kPartial;  // case 2
      v_bar = meanInnovationOfUnique();
      resolve(v_bar);
    } else {
      last_case_ = Case::kAllInterfere;  // case 3
      // Each contested landmark keeps its closest observation (eq. 5, uncompensated); their mean
      // innovation (eq. 6 over these q pairs) compensates all m observations, then NN again.
      std::vector<int>& winner = winner_;
      std::vector<double>& winner_score = winner_score_;
      winner.assign(n, -1);
      winner_score.assign(n, kInf);
      const Eigen::Vector2d zero = Eigen::Vector2d::Zero();
      for (int i = 0; i < m; ++i) {
        const int a = assign_[i];
        if (a < 0) continue;
        double mah;
        const double sc = score(i, a, zero, &mah);
        if (sc < winner_score[a]) {
          winner_score[a] = sc;
          winner[a] = i;
        }
      }
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      int q = 0;
      for (int c = 0; c < n; ++c) {
        if (winner[c] < 0) continue;
        sum += pair(winner[c], c).v;
        ++q;
      }
      v_bar = sum / q;  // q >= 1: at least one landmark is contested
      nearestAll(v_bar);
      resolve(v_bar);
    }
    last_v_bar_ = v_bar;
  }
  ++stats_.cases[static_cast<int>(last_case_)];

  // An observation left unpaired although it lies within the ambiguity gate (plain or
  // compensated) of a local landmark must not seed a duplicate of that landmark: rejected.
  if (have_table || ambiguity_gate_ > gate_) {
    for (int i = 0; i < m; ++i) {
      if (assign_[i] >= 0) continue;
      gated_[i] = 0;
      for (int c = 0; c < n && !gated_[i]; ++c) {
        if (have_table) {
          double mah;
          score(i, c, last_v_bar_, &mah);
          gated_[i] = pair(i, c).mahalanobis <= ambiguity_gate_ || mah <= ambiguity_gate_;
        } else {
          gated_[i] = ctx.individual(i, cand_[c]).mahalanobis <= ambiguity_gate_;
        }
      }
    }
  }

  // At a loop closure the joint decision replaces the shift and density tests (it weighs every
  // hypothesis they weigh, and more).
  if (p_.loop_closure_age <= 0.0 || !jointDecision(ctx)) {
    if (p_.shift_test) shiftTest(ctx);
    if (p_.landmark_density > 0.0) densityTest(ctx);
  }
  countPairings();
  for (int i = 0; i < m; ++i) {
    if (assign_[i] >= 0) result.pair(i, ctx.landmarkId(cand_[assign_[i]]));
  }
  updateMapEvidence(ctx, &result);
  handleUnpaired(ctx, &result);
  if (p_.loop_closure_age > 0.0) {
    for (int i = 0; i < m; ++i) {
      if (result.decision[i] == Decision::kPaired) last_paired_[result.landmark[i]] = stamp_;
    }
    for (LandmarkId id : result.remove) last_paired_.erase(id);
    for (LandmarkId id : result.remove) remembered_.erase(id);  // their anchor is gone
  }
  recordCoverage();
  return result;
}

// --- shift test ------------------------------------------------------------------------------

double DJNN::jointCost(const AssociationContext& ctx, const std::vector<int>& h) const {
  std::vector<std::pair<int, int>> pairs;
  double cost = 0.0;
  for (int i = 0; i < static_cast<int>(h.size()); ++i) {
    if (assign_[i] < 0) continue;  // not part of the scan's pairing
    if (h[i] >= 0) {
      pairs.emplace_back(i, cand_[h[i]]);
    } else {
      // Left unpaired: charged as a pairing at the edge of the gate.
      cost += gate_ + ctx.individual(i, cand_[assign_[i]]).log_det_S;
    }
  }
  return cost + jointInnovationCost(ctx, pairs);
}

// In a periodic layout (markers every 0.8 m along a corridor) a pose error of a spacing or more
// makes the scan fit its neighbours nearly as well: each observation's NN (and eq. 6's common
// compensation) is then a guess. The joint likelihood with the full covariance (pose correlation
// included) weighs the whole scan against the same scan shifted: each shift is the displacement
// from a paired landmark to another candidate within the gate of its observation, applied to every
// pairing (each takes the candidate nearest to its landmark plus the shift, within its gate).
void DJNN::shiftTest(const AssociationContext& ctx) {
  const int m = static_cast<int>(assign_.size());
  const int n = static_cast<int>(cand_.size());
  const EkfSlam& ekf = ctx.ekf();
  int paired = 0;
  for (int a : assign_) paired += a >= 0;
  if (paired == 0) return;
  const double base = jointCost(ctx, assign_);
  double best = kInf;
  std::vector<int> best_h, h(m);
  std::vector<Eigen::Vector2d> tried;
  for (int i = 0; i < m; ++i) {
    if (assign_[i] < 0) continue;
    for (int c = 0; c < n; ++c) {
      if (c == assign_[i] || ctx.individual(i, cand_[c]).mahalanobis > ambiguity_gate_) continue;
      const Eigen::Vector2d d = ekf.landmark(cand_[c]) - ekf.landmark(cand_[assign_[i]]);
      bool seen = false;
      for (const Eigen::Vector2d& t : tried) seen = seen || (t - d).norm() < 1e-6;
      if (seen) continue;
      tried.push_back(d);
      std::vector<char> used(n, 0);
      for (int k = 0; k < m; ++k) {
        h[k] = -1;
        if (assign_[k] < 0) continue;
        const Eigen::Vector2d target = ekf.landmark(cand_[assign_[k]]) + d;
        double nearest = kInf;
        for (int c2 = 0; c2 < n; ++c2) {
          if (used[c2] || ctx.individual(k, cand_[c2]).mahalanobis > ambiguity_gate_) continue;
          const double dist = (ekf.landmark(cand_[c2]) - target).squaredNorm();
          if (dist < nearest) {
            nearest = dist;
            h[k] = c2;
          }
        }
        if (h[k] >= 0) used[h[k]] = 1;
      }
      if (h == assign_) continue;
      const double cost = jointCost(ctx, h);
      if (cost < best) {
        best = cost;
        best_h = h;
      }
    }
  }
  if (best_h.empty() || best > base + p_.shift_margin) return;  // the pairing stands out
  if (best < base - p_.shift_margin) {
    assign_ = best_h;  // a shift is clearly likelier
    ++stats_.shifts_taken;
    return;
  }
  // Both likely: the pairings that differ are not decided on this scan.
  for (int i = 0; i < m; ++i) {
    if (assign_[i] >= 0 && best_h[i] != assign_[i]) {
      assign_[i] = -1;
      gated_[i] = 1;
    }
  }
  ++stats_.shifts_ambiguous;
}

// An observation paired with landmark j has likelihood N(v; 0, S) under that pairing, and lambda
// (per m^2) under "a landmark not in the map, or clutter". NN's gate only asks v^T S^-1 v <= chi2:
// when the pose is uncertain by a metre, S is large, N(v; 0, S) falls below the density of unmapped
// markers, and a marker never seen before is paired with an old one inside the wide gate (the
// loop closures of `fiducials`). Jointly, observations that fit one pose correction multiply
// densities of the observation noise, far above lambda^k; a lone pairing does not.
void DJNN::densityTest(const AssociationContext& ctx) {
  const int m = static_cast<int>(assign_.size());
  const double null_cost = unmappedCost(p_);
  const double log_2pi = std::log(2.0 * M_PI);
  // -2 ln N(v; 0, S) of the pairings of assign_ but `skip` (-1: none).
  std::vector<std::pair<int, int>> pairs;
  auto cost = [&](int skip) {
    pairs.clear();
    for (int i = 0; i < m; ++i) {
      if (assign_[i] >= 0 && i != skip) pairs.emplace_back(i, cand_[assign_[i]]);
    }
    return jointInnovationCost(ctx, pairs) + 2.0 * static_cast<double>(pairs.size()) * log_2pi;
  };
  // Each pairing is judged given the others (-2 ln of its conditional likelihood: the joint cost
  // with it less the joint cost without it): a marker never seen before paired with an old one a
  // metre off, next to pairings that fix the pose, stands out; withdrawn worst first.
  while (true) {
    const double all = cost(-1);
    int worst = -1;
    double worst_cost = null_cost;
    for (int i = 0; i < m; ++i) {
      if (assign_[i] < 0) continue;
      const double c = all - cost(i);
      if (!(c <= worst_cost)) {
        worst_cost = c;
        worst = i;
      }
    }
    if (worst < 0) return;
    assign_[worst] = -1;
    gated_[worst] = 1;
    ++stats_.density_withdrawn;
  }
}

// --- joint decision at loop closures ----------------------------------------------------------

// The local region (eq. 10) is placed by the pose estimate with margins for a good pose; back on
// old landmarks with a pose error of metres, a true landmark in view can lie outside it, and the
// joint decision would then never weigh the true hypothesis. Landmarks within three standard
// deviations of the pose (position, and heading at the far range) that gate with an observation
// join the candidates.
void DJNN::widenCandidates(const AssociationContext& ctx) {
  const Eigen::Matrix3d P = ctx.ekf().poseCovariance();
  const double R = p_.sensor.max_range;
  const double radius =
      R + p_.range_margin +
      3.0 * (std::sqrt(std::max(0.0, P(0, 0) + P(1, 1))) + R * std::sqrt(std::max(0.0, P(2, 2))));
  const int m = static_cast<int>(assign_.size());
  std::vector<int> added;
  for (int j : ctx.landmarksNear(sensor_pose_.head<2>(), radius)) {
    if (std::binary_search(cand_.begin(), cand_.end(), j)) continue;
    for (int i = 0; i < m; ++i) {
      if (ctx.individual(i, j).mahalanobis <= ambiguity_gate_) {
        added.push_back(j);
        break;
      }
    }
  }
  if (added.empty()) return;
  std::vector<int> paired(m, -1);
  for (int i = 0; i < m; ++i) paired[i] = assign_[i] >= 0 ? cand_[assign_[i]] : -1;
  std::vector<std::pair<int, char>> merged;
  for (std::size_t c = 0; c < cand_.size(); ++c) merged.emplace_back(cand_[c], cand_valid_[c]);
  for (int j : added) merged.emplace_back(j, 0);  // outside eq. 10, so outside eq. 7
  std::sort(merged.begin(), merged.end());
  cand_.clear();
  cand_valid_.clear();
  for (const auto& e : merged) {
    cand_.push_back(e.first);
    cand_valid_.push_back(e.second);
  }
  for (int i = 0; i < m; ++i) {
    if (paired[i] >= 0) {
      assign_[i] =
          static_cast<int>(std::lower_bound(cand_.begin(), cand_.end(), paired[i]) - cand_.begin());
    }
  }
}

// Back on markers last seen long ago, the pose error can be a marker spacing or more: NN (with
// eq. 6's compensation) and the shift test then pick one of several hypotheses that fit nearly
// equally, and a wrong one corrupts the map for good. The joint maximum-likelihood assignment over
// the gated candidates, "not in the map" scored by the densities, decides each observation only
// when every hypothesis deciding it otherwise is joint_margin less likely; the rest are held
// (rejected: no pairing, and no tentative feature that could duplicate an old landmark).
// Returns false, changing nothing, when no gated landmark is older than loop_closure_age.
bool DJNN::jointDecision(const AssociationContext& ctx) {
  const int m = static_cast<int>(assign_.size());
  widenCandidates(ctx);
  bool old = false;
  for (int i = 0; i < m && !old; ++i) {
    for (int j : cand_) {
      if (ctx.individual(i, j).mahalanobis > ambiguity_gate_) continue;
      const auto it = last_paired_.find(ctx.landmarkId(j));
      old = old || it == last_paired_.end() || stamp_ - it->second > p_.loop_closure_age;
    }
  }
  if (!old) {
    endHeldStreak();
    held_window_.clear();
    return false;
  }
  // Remembered features enter as virtual observations paired with their anchor landmark: the
  // observation moved by the offset (z' = h(anchor) + z - h(anchor + offset)), its noise grown by
  // the offset's covariance, so that the joint covariance keeps the anchor's correlations.
  std::vector<Observation> ext;
  std::vector<std::vector<JointMlExtra>> extra(m);
  std::unordered_map<int, LandmarkId> key_anchor;
  bool any_extra = false;
  if (p_.remembered_sightings > 0) {
    ext = ctx.observations();
    const Eigen::Vector3d pose = ctx.robotPose();
    const auto addOption = [&](int j, const Eigen::Vector2d& offset, const Eigen::Matrix2d& cov,
                               int key, double cost) {
      const Eigen::Vector2d at = ctx.ekf().landmark(j) + offset;
      for (int i = 0; i < m; ++i) {
        const Observation& o = ctx.observations()[i];
        Eigen::Matrix2d H_m;
        const Eigen::Vector2d z_hat = ctx.model().predict(pose, at, o.kind, nullptr, &H_m);
        Observation v = o;
        v.z = ctx.prediction(j, o.kind).z_hat + RangeBearingModel::innovation(o.z, z_hat, o.kind);
        v.R = o.R + H_m * cov * H_m.transpose();
        ext.push_back(v);
        extra[i].push_back({static_cast<int>(ext.size()) - 1, j, key, cost});
      }
    };
    std::unordered_map<LandmarkId, int> local;  // anchor id -> state index
    for (int j : cand_) {
      local[ctx.landmarkId(j)] = j;
      const auto it = remembered_.find(ctx.landmarkId(j));
      if (it == remembered_.end()) continue;
      for (const Remembered& r : it->second) {
        addOption(j, r.offset, r.cov, r.key, 0.0);
        key_anchor[r.key] = it->first;
      }
    }
    // The live tentative features in view are options too: a marker seen a few times on this
    // pass is likelier itself than an old landmark a pose shift away. One started by a held
    // observation may be a duplicate of the old landmark the closure is about, placed from the
    // uncorrected pose: held_birth_cost charges it.
    queryTentatives(sensor_pose_.head<2>(), p_.sensor.max_range + p_.range_margin, &tent_near_);
    for (int slot : tent_near_) {
      const Tentative& t = tentative_[slot];
      const auto it = local.find(t.anchor);
      if (it == local.end() || t.sightings < p_.remembered_sightings) continue;
      addOption(it->second, t.anchor_offset, t.anchor_cov, kLiveKeyBase + slot,
                t.held_birth ? p_.held_birth_cost : 0.0);
    }
  }
  const AssociationContext ectx(ctx.ekf(), ctx.model(), ctx.landmarkIndex(),
                                ext.empty() ? ctx.observations() : ext, ctx.stamp());
  JointMlProblem problem;
  problem.null_cost = unmappedCost(p_);
  for (int i = 0; i < m; ++i) {
    std::vector<int> gated;
    for (int j : cand_) {
      if (ctx.individual(i, j).mahalanobis <= ambiguity_gate_) gated.push_back(j);
    }
    std::vector<JointMlExtra> kept;
    for (const JointMlExtra& e : extra[i]) {
      if (ectx.individual(e.obs, e.landmark).mahalanobis <= ambiguity_gate_) kept.push_back(e);
    }
    if (gated.empty() && kept.empty()) continue;
    any_extra = any_extra || !kept.empty();
    if (p_.landmark_spacing > 0.0 || p_.coverage_cell > 0.0) {
      problem.null_costs.push_back(unmappedCostOf(ctx, i, gated));
    }
    problem.obs.push_back(i);
    problem.candidates.push_back(std::move(gated));
    problem.extra.push_back(std::move(kept));
  }
  if (!any_extra) problem.extra.clear();
  ++stats_.joint_scans;
  // With held scans, alternatives the window may prefer are searched farther (kWindowSearch).
  const bool window = p_.held_window_scans > 0 && !held_window_.empty();
  const double margin =
      window && p_.held_window_margin > 0.0 ? p_.held_window_margin : p_.joint_margin;
  JointMlDecision d = jointMaximumLikelihood(
      ectx, problem, window ? std::max(kWindowSearch * p_.joint_margin, margin) : margin);
  if (window) heldWindowDecision(ctx, ectx, problem, &d);
  // After held scans, a lead that did not lead them is one scan's noise: held again.
  Lead lead;
  if (p_.held_confirmations > 0) lead = leadOf(ctx, problem, d);
  const bool unconfirmed = !held_leads_.empty() && !leadRepeats(lead);
  held_scan_ = false;
  stats_.joint_incomplete += !d.complete;
  std::vector<int> held;
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const int i = problem.obs[k];
    if (!d.complete || unconfirmed || d.alternative_cost[k] < d.best_cost + margin) {
      held.push_back(static_cast<int>(k));
      assign_[i] = -1;
      ++stats_.joint_held;
      held_scan_ = p_.remembered_sightings > 0;
      // Held. With remembered features its sighting still feeds a tentative feature (never admitted
      // while held): a marker seen on this pass is then an option of the next scans' decisions.
      gated_[i] = p_.remembered_sightings > 0 ? 0 : 1;
      if (p_.remembered_sightings > 0) force_new_[i] = kHeld;
    } else if (d.best[k] >= 0) {
      assign_[i] =
          static_cast<int>(std::lower_bound(cand_.begin(), cand_.end(), d.best[k]) - cand_.begin());
    } else if (d.best[k] <= -2 - kLiveKeyBase) {
      assign_[i] = -1;  // a live tentative feature: not in the map, matched to it below
      gated_[i] = 0;
    } else if (d.best[k] <= -2) {
      // A remembered feature: admitted from this observation, and forgotten as such.
      const int key = -2 - d.best[k];
      std::vector<Remembered>& list = remembered_[key_anchor[key]];
      list.erase(std::remove_if(list.begin(), list.end(),
                                [key](const Remembered& r) { return r.key == key; }),
                 list.end());
      assign_[i] = -1;
      gated_[i] = 0;
      force_new_[i] = kAdmit;
    } else {
      assign_[i] = -1;  // decided: not in the map
      gated_[i] = 0;
    }
  }
  if (held.empty()) {
    endHeldStreak();
  } else {
    ++held_streak_;
    if (p_.held_confirmations > 0) {
      held_leads_.push_back(lead);
      while (static_cast<int>(held_leads_.size()) > p_.held_confirmations) held_leads_.pop_front();
    }
  }
  if (p_.held_window_scans > 0) keepHeld(ctx, ectx, problem, held);
  return true;
}

// A closure is no longer held: count the streak (stats) and forget the leads it kept.
void DJNN::endHeldStreak() {
  stats_.held_streaks += held_streak_ > 0;
  stats_.held_streak_scans += held_streak_;
  held_streak_ = 0;
  held_leads_.clear();
}

// --- evidence (eq. 9) ----------------------------------------------------------------------------

double DJNN::bump(double evidence, double r) const {
  const double t = evidence + r;
  return p_.max_evidence > 0 ? std::min(t, static_cast<double>(p_.max_evidence)) : t;
}

// The paper's counter tests "hit rate above 1/2", the midpoint between the hit rate of a real
// landmark (1) and of a pseudo-feature (0). With detection probability P_D and a false-detection
// chance P_F in the feature's gate the threshold becomes the midpoint tau = (P_D + P_F) / 2, and
// T = 2 (hits - tau scans): the same units, so admit / remove thresholds keep their meaning
// (docs/djnn.md, "Detection probability").
double DJNN::evidenceStep(bool hit, const Eigen::Matrix2d& C) const {
  const double pd = p_.sensor.detection_probability;
  double pf = 0.0;
  if (p_.sensor.clutter_density > 0.0) {
    // Gate area of the feature: the ellipse e^T C^-1 e <= tentative gate.
    const double det = C.determinant();
    const double area = det > 0.0 ? M_PI * tentative_gate_ * std::sqrt(det) : 0.0;
    pf = std::min(0.5 * pd, p_.sensor.falseDetectionProbability(area));
  }
  const double tau = 0.5 * (pd + pf);
  return hit ? 2.0 * (1.0 - tau) : -2.0 * tau;
}

void DJNN::updateMapEvidence(const AssociationContext& ctx, AssociationResult* result) {
  const EkfSlam& ekf = ctx.ekf();
  const Eigen::Vector2d origin = sensor_pose_.head<2>();
  const double c = std::cos(sensor_pose_(2));
  const double s = std::sin(sensor_pose_(2));
  if (p_.bias_test) {
    // A landmark whose innovations keep pointing one way follows a moving object: its pairing of
    // this scan is withdrawn (the return is rejected, not made tentative) and it leaves the map.
    const int m = static_cast<int>(assign_.size());
    for (int i = 0; i < m; ++i) {
      const int k = assign_[i];
      if (k < 0 || !biased(ctx, i, k)) continue;
      const LandmarkId id = ctx.landmarkId(cand_[k]);
      result->decision[i] = Decision::kRejected;
      result->landmark[i] = kNoLandmark;
      assign_[i] = -1;
      gated_[i] = 1;
      count_[k] = 0;
      Bias& b = bias_[id];
      if (p_.bias_keep_pairings > 0 && b.pairings >= p_.bias_keep_pairings) {
        // Established by many unbiased pairings: something moving past it, not the landmark.
        b = Bias();
        b.pairings = p_.bias_keep_pairings;
        ++stats_.biased_kept;
        continue;
      }
      result->remove.push_back(id);
      evidence_.erase(id);
      bias_.erase(id);
      ++stats_.removed;
      ++stats_.biased_removed;
    }
  }
  // Only the local region is visited: a landmark outside it cannot be inside the sensor region,
  // so its r_k is 0 anyway.
  for (int k = 0; k < static_cast<int>(cand_.size()); ++k) {
    const LandmarkId id = ctx.landmarkId(cand_[k]);
    if (p_.bias_test &&
        std::find(result->remove.begin(), result->remove.end(), id) != result->remove.end()) {
      continue;  // removed by the bias test above
    }
    auto it = evidence_.try_emplace(id, p_.initial_evidence).first;
    double r = 0.0;
    if (count_[k] > 0) {
      r = evidenceStep(true, ekf.landmarkCovariance(cand_[k]));
    } else {
      const Eigen::Vector2d d = ekf.landmark(cand_[k]) - origin;
      const Eigen::Vector2d ps(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
      // A scan the joint decision held undecided says nothing about which landmark was missed.
      if (!held_scan_ && inRegion(ps, penalty_radial_, penalty_lateral_)) {
        r = evidenceStep(false, ekf.landmarkCovariance(cand_[k]));
      }
    }
    it->second = bump(it->second, r);
    if (it->second <= p_.remove_evidence + kEvidenceEps) {
      result->remove.push_back(id);
      evidence_.erase(it);
      bias_.erase(id);
      ++stats_.removed;
    }
  }
  // Counters of landmarks removed by someone else: swept when they could dominate (amortised).
  if (evidence_.size() > 2 * ekf.numLandmarks() + 64) {
    for (auto it = evidence_.begin(); it != evidence_.end();) {
      it = ekf.contains(it->first) ? std::next(it) : evidence_.erase(it);
    }
  }
  if (bias_.size() > 2 * ekf.numLandmarks() + 64) {
    for (auto it = bias_.begin(); it != bias_.end();) {
      it = ekf.contains(it->first) ? std::next(it) : bias_.erase(it);
    }
  }
}

// The innovation v of a static landmark in a consistent filter is white with covariance S, so a
// discounted sum of them stays within chi2(2); a landmark dragged along by a mover sees the
// mover's displacement in every innovation. Summed in the world frame (G = d(position)/dz = H_m^-1)
// because the sensor frame turns between scans.
bool DJNN::biased(const AssociationContext& ctx, int obs, int cand) {
  const AssociationContext::Individual ind = ctx.individual(obs, cand_[cand]);
  Matrix23d G_pose;
  Eigen::Matrix2d G_obs;
  const Observation& o = ctx.observations()[obs];
  ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
  Bias& b = bias_[ctx.landmarkId(cand_[cand])];
  b.sum = bias_decay_ * b.sum + G_obs * ind.v;
  b.cov = (bias_decay_ * bias_decay_) * b.cov + G_obs * ind.S * G_obs.transpose();
  ++b.pairings;
  if (b.pairings < p_.bias_min_pairings) return false;
  return b.sum.dot(b.cov.inverse() * b.sum) > bias_gate_;
}

DJNN::CellKey DJNN::tentativeKey(const Eigen::Vector2d& p) const {
  return packCell(cellOf(p.x(), tentative_cell_), cellOf(p.y(), tentative_cell_));
}

void DJNN::queryTentatives(const Eigen::Vector2d& center, double radius,
                           std::vector<int>* out) const {
  out->clear();
  if (tentative_cells_.empty()) return;
  const std::int64_t x0 = cellOf(center.x() - radius, tentative_cell_);
  const std::int64_t x1 = cellOf(center.x() + radius, tentative_cell_);
  const std::int64_t y0 = cellOf(center.y() - radius, tentative_cell_);
  const std::int64_t y1 = cellOf(center.y() + radius, tentative_cell_);
  const double r2 = radius * radius;
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      auto it = tentative_cells_.find(packCell(ix, iy));
      if (it == tentative_cells_.end()) continue;
      for (int slot : it->second) {
        if ((tentative_[slot].position - center).squaredNorm() < r2) out->push_back(slot);
      }
    }
  }
  std::sort(out->begin(), out->end());
}

int DJNN::addTentative(const Eigen::Vector2d& pos, const Eigen::Matrix2d& cov, double stamp,
                       const Eigen::Vector2d& heading_lever) {
  int slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<int>(tentative_.size());
    tentative_.emplace_back();
  }
  Tentative& t = tentative_[slot];
  t.position = pos;
  t.alive = true;
  tentative_cells_[tentativeKey(pos)].push_back(slot);
  startTentative(slot, pos, cov, stamp, heading_lever);
  return slot;
}

void DJNN::startTentative(int slot, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                          double stamp, const Eigen::Vector2d& heading_lever) {
  Tentative& t = tentative_[slot];
  t.cov = C;
  t.heading_lever = heading_lever;
  t.evidence = bump(0.0, evidenceStep(true, C));  // seen now
  t.last_seen = stamp;
  t.sightings = 1;
  t.residual = 0.0;
  t.first_seen = stamp;
  t.track_info.setZero();
  t.track_vec.setZero();
  if (p_.static_min_speed > 0.0) addToTrack(&t, z, C, stamp);
  moveTentative(slot, z);
}

// Weighted least squares of z_i = p + (t_i - t_0) v + e_i, e_i ~ N(0, C_i), in information form.
void DJNN::addToTrack(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                      double stamp) {
  const double dt = stamp - t->first_seen;
  const Eigen::Matrix2d W = C.inverse();
  t->track_info.topLeftCorner<2, 2>() += W;
  t->track_info.topRightCorner<2, 2>() += dt * W;
  t->track_info.bottomLeftCorner<2, 2>() += dt * W;
  t->track_info.bottomRightCorner<2, 2>() += dt * dt * W;
  const Eigen::Vector2d wz = W * z;
  t->track_vec.head<2>() += wz;
  t->track_vec.tail<2>() += dt * wz;
}

bool DJNN::trackVelocity(const Tentative& t, Eigen::Matrix2d* J, double* statistic) {
  // Position marginalised out (Schur complement): J = L_vv - L_vp L_pp^-1 L_pv, and
  // v_hat = J^-1 b with b = y_v - L_vp L_pp^-1 y_p, so v_hat^T J v_hat = b^T J^-1 b.
  const Eigen::Matrix2d Lpp_inv = t.track_info.topLeftCorner<2, 2>().inverse();
  const Eigen::Matrix2d Lvp = t.track_info.bottomLeftCorner<2, 2>();
  *J = t.track_info.bottomRightCorner<2, 2>() - Lvp * Lpp_inv * Lvp.transpose();
  const Eigen::Vector2d b = t.track_vec.tail<2>() - Lvp * Lpp_inv * t.track_vec.head<2>();
  const double det = J->determinant();
  // All sightings at one stamp (or one): no velocity information yet.
  if (!(det > 1e-12 * J->squaredNorm()) || !(J->trace() > 0.0)) return false;
  *statistic = b.dot(J->inverse() * b);
  return std::isfinite(*statistic);
}

// A marker seen a few times on a first pass but never admitted leaves a hole in the map; back there
// after a loop, "not in the map" would cost its observation the density of unmapped landmarks while
// a hypothesis shifted by a marker spacing pairs it: the likelihood would prefer the shift. Its
// position relative to a neighbouring landmark, known to the observation noise, is kept instead.
void DJNN::anchorTentative(const AssociationContext& ctx, int slot) {
  if (p_.remembered_sightings <= 0) return;
  Tentative& t = tentative_[slot];
  double best = kInf;
  t.anchor = kNoLandmark;
  for (int j : cand_) {
    // Only a landmark paired recently moves with the pose the feature was placed from; an old one
    // (at a loop closure) is off by the whole pose error.
    const auto it = last_paired_.find(ctx.landmarkId(j));
    if (it == last_paired_.end() || stamp_ - it->second > p_.loop_closure_age) continue;
    const Eigen::Vector2d off = t.position - ctx.ekf().landmark(j);
    if (off.squaredNorm() >= best) continue;
    best = off.squaredNorm();
    t.anchor = ctx.landmarkId(j);
    t.anchor_offset = off;
  }
  if (t.anchor == kNoLandmark) return;
  // The feature's fused observation noise, as much again for the anchor's estimate relative to
  // the pose it was seen from, and the offset turned by the heading's uncertainty.
  const Eigen::Vector2d perp(-t.anchor_offset.y(), t.anchor_offset.x());
  t.anchor_cov =
      2.0 * t.cov + std::max(0.0, ctx.ekf().poseCovariance()(2, 2)) * perp * perp.transpose();
  // Within its gate of the anchor it is that landmark seen again (a held observation): no
  // feature of its own.
  if (t.anchor_offset.dot(t.anchor_cov.inverse() * t.anchor_offset) <= tentative_gate_) {
    t.anchor = kNoLandmark;
  }
}

void DJNN::dropTentative(int slot, bool stale) {
  Tentative& t = tentative_[slot];
  if (!t.alive) return;
  if (stale && p_.remembered_sightings > 0 && t.sightings >= p_.remembered_sightings &&
      t.anchor != kNoLandmark) {
    remembered_[t.anchor].push_back({t.anchor_offset, t.anchor_cov, remembered_keys_++});
    ++stats_.remembered;
  }
  t.anchor = kNoLandmark;
  auto it = tentative_cells_.find(tentativeKey(t.position));
  if (it != tentative_cells_.end()) {
    std::vector<int>& v = it->second;
    auto pos = std::find(v.begin(), v.end(), slot);
    if (pos != v.end()) {
      *pos = v.back();
      v.pop_back();
    }
    if (v.empty()) tentative_cells_.erase(it);
  }
  t.alive = false;
  free_slots_.push_back(slot);
}

void DJNN::moveTentative(int slot, const Eigen::Vector2d& pos) {
  Tentative& t = tentative_[slot];
  const CellKey from = tentativeKey(t.position);
  const CellKey to = tentativeKey(pos);
  t.position = pos;
  if (from == to) return;
  auto it = tentative_cells_.find(from);
  if (it != tentative_cells_.end()) {
    std::vector<int>& v = it->second;
    auto p = std::find(v.begin(), v.end(), slot);
    if (p != v.end()) {
      *p = v.back();
      v.pop_back();
    }
    if (v.empty()) tentative_cells_.erase(it);
  }
  tentative_cells_[to].push_back(slot);
}

bool DJNN::longEnough(int slot) const {
  if (!p_.static_test || p_.static_min_speed <= 0.0) return true;
  Eigen::Matrix2d J;
  double v2 = 0.0;
  if (!trackVelocity(tentative_[slot], &J, &v2)) return false;
  // Least eigenvalue of the symmetric 2 x 2 J: the direction the velocity is least known in.
  const double half_trace = 0.5 * J.trace();
  const double gap = std::sqrt(std::max(0.0, half_trace * half_trace - J.determinant()));
  return half_trace - gap >= baseline_information_;
}

void DJNN::handleUnpaired(const AssociationContext& ctx, AssociationResult* result) {
  const int m = static_cast<int>(ctx.numObservations());
  const double stamp = ctx.stamp();
  const Eigen::Vector3d pose = ctx.robotPose();
  const Eigen::Matrix3d P_vv = ctx.ekf().poseCovariance();
  const Eigen::Vector2d origin = sensor_pose_.head<2>();
  const double c = std::cos(sensor_pose_(2));
  const double s = std::sin(sensor_pose_(2));

  const Eigen::Matrix2d jitter =
      p_.static_test ? (p_.static_jitter * p_.static_jitter * Eigen::Matrix2d::Identity()).eval()
                     : Eigen::Matrix2d::Zero().eval();
  queryTentatives(origin, p_.sensor.max_range + p_.range_margin, &tent_near_);
  tent_hit_.assign(tent_near_.size(), 0);

  // Observations that may be a feature not yet in the map: unpaired, not ambiguous, inside the
  // effective range (beyond R nothing can be paired, so they would only duplicate landmarks).
  std::vector<Sighting>& seen = sightings_;
  seen.assign(m, Sighting{Eigen::Vector2d::Zero(), Eigen::Matrix2d::Zero(), Eigen::Vector2d::Zero(),
                          -1, false});
  const double heading_var = p_.static_heading ? std::max(0.0, P_vv(2, 2)) : 0.0;
  std::vector<TentativePair>& pairs = tentative_pairs_;
  pairs.clear();
  for (int i = 0; i < m; ++i) {
    const Observation& o = ctx.observations()[i];
    if (result->decision[i] == Decision::kPaired || gated_[i]) continue;
    if (!(RangeBearingModel::range(o.z, o.kind) < p_.sensor.max_range) || !o.z.allFinite()) {
      continue;
    }
    seen[i].eligible = true;
    Matrix23d G_pose;
    Eigen::Matrix2d G_obs;
    seen[i].pos = ctx.model().inverse(pose, o.z, o.kind, &G_pose, &G_obs);
    seen[i].cov_obs = G_obs * o.R * G_obs.transpose();
    seen[i].heading_lever = G_pose.col(2);
    // Gate on position: observation noise of both sightings plus the current pose covariance once
    // (an upper bound on the pose error accumulated between the sightings; using it twice would
    // double-count the correlated part).
    // With tentative_follow_pose the features move with the pose's corrections, so the pose error
    // is common to both sightings: only the heading error's share that differs with the lever
    // remains (as in the static test).
    const Eigen::Matrix2d C = p_.tentative_follow_pose
                                  ? seen[i].cov_obs
                                  : (seen[i].cov_obs + G_pose * P_vv * G_pose.transpose()).eval();
    const double lever_var = p_.tentative_follow_pose ? std::max(0.0, P_vv(2, 2)) : 0.0;
    for (int k = 0; k < static_cast<int>(tent_near_.size()); ++k) {
      const Tentative& t = tentative_[tent_near_[k]];
      const Eigen::Vector2d dl = seen[i].heading_lever - t.heading_lever;
      const Eigen::Matrix2d S = C + t.cov + lever_var * dl * dl.transpose();
      const Eigen::Vector2d e = seen[i].pos - t.position;
      const double d2 = e.dot(S.inverse() * e);
      if (d2 <= tentative_gate_) pairs.push_back({d2, i, k});
    }
  }
  // One-to-one, closest first.
  std::sort(pairs.begin(), pairs.end(), [](const TentativePair& a, const TentativePair& b) {
    return a.d2 < b.d2 ||
           (a.d2 == b.d2 && (a.obs < b.obs || (a.obs == b.obs && a.local < b.local)));
  });
  for (const TentativePair& cnd : pairs) {
    if (seen[cnd.obs].slot >= 0 || tent_hit_[cnd.local]) continue;
    tent_hit_[cnd.local] = 1;
    const int slot = tent_near_[cnd.local];
    seen[cnd.obs].slot = slot;
    Tentative& t = tentative_[slot];
    const Eigen::Vector2d& z = seen[cnd.obs].pos;
    const Eigen::Matrix2d C = seen[cnd.obs].cov_obs + jitter;
    if (p_.static_test) {
      // Recursive least-squares residual of the sightings about one static point: the new
      // sighting's normalised distance to the fused position of the earlier ones.
      const Eigen::Vector2d e = z - t.position;
      // A heading error common to the sightings moves each by its lever times the error: they
      // differ by the change of lever (zero without static_heading).
      const Eigen::Vector2d dl = seen[cnd.obs].heading_lever - t.heading_lever;
      t.residual += e.dot((t.cov + C + heading_var * dl * dl.transpose()).inverse() * e);
      ++t.sightings;
      bool moving = t.residual > static_gate_(2 * (t.sightings - 1));
      if (p_.static_min_speed > 0.0 && !moving) {
        // Against a constant velocity (2 dof) rather than any scatter (2 (k - 1) dof): the
        // stronger test for an object moving steadily.
        addToTrack(&t, z, C, stamp);
        Eigen::Matrix2d J;
        double v2 = 0.0;
        moving = trackVelocity(t, &J, &v2) && v2 > velocity_gate_;
      }
      if (moving) {
        // Not one static point (a slow mover): its history is void; restart from this sighting.
        startTentative(slot, z, C, stamp, seen[cnd.obs].heading_lever);
        ++stats_.static_restarts;
        continue;
      }
    }
    // Fuse the sightings (information-weighted on their observation noise).
    const Eigen::Matrix2d K = t.cov * (t.cov + C).inverse();
    const Eigen::Vector2d fused = t.position + K * (z - t.position);
    t.heading_lever += K * (seen[cnd.obs].heading_lever - t.heading_lever);
    t.cov = (Eigen::Matrix2d::Identity() - K) * t.cov;
    t.cov = 0.5 * (t.cov + t.cov.transpose()).eval();
    t.evidence = bump(t.evidence, evidenceStep(true, t.cov));
    t.last_seen = stamp;
    moveTentative(slot, fused);
  }

  // Tentative features in the region that were not seen this scan: r_k = -1 inside the sensor
  // region, 0 outside (eq. 9); stale ones time out.
  for (int k = 0; k < static_cast<int>(tent_near_.size()); ++k) {
    if (tent_hit_[k]) continue;
    const int slot = tent_near_[k];
    Tentative& t = tentative_[slot];
    const Eigen::Vector2d d = t.position - origin;
    const Eigen::Vector2d ps(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
    if (inRegion(ps, penalty_radial_, penalty_lateral_)) {
      t.evidence = bump(t.evidence, evidenceStep(false, t.cov));
    }
    const bool stale = p_.tentative_timeout > 0.0 && stamp - t.last_seen > p_.tentative_timeout;
    if (t.evidence <= p_.remove_evidence + kEvidenceEps || stale) {
      dropTentative(slot, stale && t.evidence > p_.remove_evidence + kEvidenceEps);
      ++stats_.tentative_dropped;
    }
  }

  // Decisions: admitted when T reaches the admission threshold (eq. 9), else tentative.
  for (int i = 0; i < m; ++i) {
    if (!seen[i].eligible) continue;
    int slot = seen[i].slot;
    if (slot < 0) {
      slot = addTentative(seen[i].pos, seen[i].cov_obs + jitter, stamp, seen[i].heading_lever);
      tentative_[slot].held_birth = force_new_[i] == kHeld;
    }
    anchorTentative(ctx, slot);
    const double t = tentative_[slot].evidence;
    // With P_D < 1 a hit is worth more than 1, so T reaches the threshold after fewer sightings
    // than at P_D = 1; the static test still needs the paper's admit_evidence sightings of one
    // static point (and the time they span) to tell a slow mover from a landmark. At P_D = 1,
    // T >= admit_evidence already implies as many sightings since the last restart.
    const bool enough_sightings =
        !p_.static_test || tentative_[slot].sightings >= p_.admit_evidence;
    // Two landmarks are never closer than landmark_spacing: a source that certainly lies that
    // close to a map landmark is that landmark seen off (a pose made over-confident by a large
    // correction) or clutter, and admitting it would make a duplicate. It stays tentative.
    const bool admitting = force_new_[i] == kAdmit ||
                           (force_new_[i] != kHeld && t >= p_.admit_evidence - kEvidenceEps &&
                            enough_sightings && longEnough(slot));
    if (admitting && withinSpacing(ctx, i, cand_)) {
      result->decision[i] = Decision::kTentative;
      ++stats_.spacing_refused;
    } else if (force_new_[i] == kHeld) {
      result->decision[i] = Decision::kTentative;
    } else if (force_new_[i] == kAdmit) {
      result->decision[i] = Decision::kNew;  // on a remembered feature (joint decision)
      pending_new_[i] = std::max(t, static_cast<double>(p_.admit_evidence));
      dropTentative(slot);
      ++stats_.admitted;
      ++stats_.remembered_admitted;
    } else if (t >= p_.admit_evidence - kEvidenceEps && enough_sightings && longEnough(slot)) {
      result->decision[i] = Decision::kNew;
      pending_new_[i] = t;
      dropTentative(slot);  // now the pipeline's landmark; its counter starts in landmarkAdded()
      ++stats_.admitted;
    } else {
      result->decision[i] = Decision::kTentative;
    }
  }

  // Amortised timeout sweep over the whole tentative set (features the robot never revisits).
  if (p_.tentative_timeout > 0.0 && !tentative_.empty()) {
    for (std::size_t n = 0; n < kSweepPerScan && n < tentative_.size(); ++n) {
      tentative_sweep_ = (tentative_sweep_ + 1) % tentative_.size();
      Tentative& t = tentative_[tentative_sweep_];
      if (t.alive && stamp - t.last_seen > p_.tentative_timeout) {
        dropTentative(static_cast<int>(tentative_sweep_), true);
        ++stats_.tentative_dropped;
      }
    }
  }
}

void DJNN::landmarkAdded(int obs, LandmarkId id) {
  double t = p_.admit_evidence;
  if (obs >= 0 && obs < static_cast<int>(pending_new_.size()) && pending_new_[obs] >= 0) {
    t = pending_new_[obs];
  }
  evidence_[id] = t;
  if (p_.loop_closure_age > 0.0) last_paired_[id] = stamp_;
}

// A tentative feature was placed from the pose estimate of its sightings, so its error is that
// pose's error: when an update corrects the pose, a landmark initialised from it would move along
// (its cross-covariance with the pose is G_x P_vv), and the tentative feature follows the same
// rigid motion. Only those within reach of the sensor: the others' next sightings are far off.
void DJNN::poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) {
  held_window_.clear();  // the held scans' poses are no longer the odometry's alone
  if (!p_.tentative_follow_pose || tentative_cells_.empty()) return;
  const double dth = wrapAngle(posterior(2) - prior(2));
  const Eigen::Matrix2d Rot = Eigen::Rotation2Dd(dth).toRotationMatrix();
  queryTentatives(prior.head<2>(), p_.sensor.max_range + p_.range_margin, &tent_near_);
  for (int slot : tent_near_) {
    Tentative& t = tentative_[slot];
    t.cov = Rot * t.cov * Rot.transpose();
    t.heading_lever = Rot * t.heading_lever;
    moveTentative(slot, posterior.head<2>() + Rot * (t.position - prior.head<2>()));
  }
}

void DJNN::landmarkLoaded(LandmarkId id, std::uint32_t times_observed) {
  // A saved landmark was confirmed that many times: it survives as many misses (the evidence it
  // would have had with no miss), at least the admission level, within the cap.
  long t =
      std::max<long>({static_cast<long>(times_observed), p_.admit_evidence, p_.initial_evidence});
  if (p_.max_evidence > 0) t = std::min<long>(t, p_.max_evidence);
  evidence_[id] = static_cast<double>(std::min<long>(t, kMaxEvidence));
}

int DJNN::evidence(LandmarkId id) const {
  auto it = evidence_.find(id);
  // Whole units (exact for P_D = 1 without clutter, where every step is +-1).
  return it != evidence_.end() ? static_cast<int>(std::floor(it->second + kEvidenceEps))
                               : p_.initial_evidence;
}

std::vector<TentativeFeature> DJNN::tentativeFeatures() const {
  std::vector<TentativeFeature> out;
  for (const Tentative& t : tentative_) {
    if (t.alive)
      out.push_back({t.position, static_cast<int>(std::floor(t.evidence + kEvidenceEps))});
  }
  return out;
}

}  // namespace ekf_slam
