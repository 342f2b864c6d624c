// DJNN as seed 000 states it (djnn_paper.h; ALGORITHMS.md section 4).
#include "ekf_slam/core/association/djnn/djnn_paper.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/angles.h"
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
Eigen::Vector2d compensate(const Eigen::Vector2d& v, const Eigen::Vector2d& v_bar,
                           MeasurementKind kind) {
  if (kind == MeasurementKind::kCartesian) return v - v_bar;
  return Eigen::Vector2d(v(0) - v_bar(0), wrapAngle(v(1) - v_bar(1)));
}

}  // namespace

// --- parameters ----------------------------------------------------------------------------------

void DjnnPaperParams::read(const ParameterReader& r) {
  const DjnnPaperParams def;  // the documented defaults
  sensor = readSensorModel(r, def.sensor);
  range_margin = r.nonNegative("range_margin", def.range_margin);
  if (range_margin >= sensor.max_range) {
    r.fail("range_margin", "must be smaller than sensor_range (eq. 7 shrinks R by it)");
  }
  angle_margin = r.inRange("angle_margin", def.angle_margin, 0.0, M_PI / 2);
  individual_probability = r.probability("individual_probability", def.individual_probability);
  wide_gate_factor = r.inRange("wide_gate_factor", def.wide_gate_factor, 1.0, 1.0e6);
  admit_evidence = r.integer("admit_evidence", def.admit_evidence, 1, kMaxEvidence);
  remove_evidence =
      r.integer("remove_evidence", def.remove_evidence, -kMaxEvidence, admit_evidence - 1);
  initial_evidence =
      r.integer("initial_evidence", def.initial_evidence, remove_evidence + 1, kMaxEvidence);
  tentative_gate_probability =
      r.probability("tentative_gate_probability", def.tentative_gate_probability);
  tentative_timeout = r.nonNegative("tentative_timeout", def.tentative_timeout);
  penalty_region = r.text("penalty_region", def.penalty_region, {"sensor", "valid"});
}

// --- evidence steps ------------------------------------------------------------------------------

void EvidenceModel::configure(const SensorModel& sensor, double tentative_gate) {
  sensor_ = sensor;
  tentative_gate_ = tentative_gate;
}

double EvidenceModel::step(bool hit, const Eigen::Matrix2d& C, double detectable) const {
  const double pd = sensor_.detection_probability * detectable;
  double pf = 0.0;
  if (sensor_.clutter_density > 0.0) {
    // Gate area of the feature: the ellipse e^T C^-1 e <= tentative gate.
    const double det = C.determinant();
    const double area = det > 0.0 ? M_PI * tentative_gate_ * std::sqrt(det) : 0.0;
    pf = std::min(0.5 * pd, sensor_.falseDetectionProbability(area));
  }
  const double tau = 0.5 * (pd + pf);
  return hit ? 2.0 * (1.0 - tau) : -2.0 * tau;
}

// --- configuration -------------------------------------------------------------------------------

void DjnnPaper::configure(const DjnnPaperParams& params) {
  p_ = params;
  gate_ = chi2Quantile(p_.individual_probability, 2);
  wide_gate_ = p_.wide_gate_factor * gate_;
  tentative_gate_ = chi2Quantile(p_.tentative_gate_probability, 2);
  model_.configure(p_.sensor, tentative_gate_);
  tentatives_.setCell(0.5 * (p_.sensor.max_range + p_.range_margin));
  if (p_.penalty_region == "valid") {
    penalty_radial_ = -p_.range_margin;
    penalty_lateral_ = -(p_.angle_margin * p_.sensor.max_range);
  } else {
    penalty_radial_ = 0.0;
    penalty_lateral_ = 0.0;
  }
  reset();
}

void DjnnPaper::setDetectionProbability(double pd) {
  // Only the one number: configure() would copy the sensor model (its polygon) every scan.
  p_.sensor.detection_probability = std::clamp(pd, 0.05, 1.0);
  model_.setDetectionProbability(p_.sensor.detection_probability);
}

void DjnnPaper::reset() {
  evidence_.clear();
  tentatives_.clear();
  ended_.clear();
  restarted_.clear();
}

double DjnnPaper::evidenceValue(LandmarkId id) const {
  auto it = evidence_.find(id);
  return it != evidence_.end() ? it->second : p_.initial_evidence;
}

int DjnnPaper::evidence(LandmarkId id) const {
  auto it = evidence_.find(id);
  // Whole units (exact for P_D = 1 without clutter, where every step is +-1).
  return it != evidence_.end() ? static_cast<int>(std::floor(it->second + kEvidenceEps))
                               : p_.initial_evidence;
}

Eigen::Vector2d DjnnPaper::inSensorFrame(const LocalScan& scan, const Eigen::Vector2d& p) {
  const double c = std::cos(scan.sensor_pose(2));
  const double s = std::sin(scan.sensor_pose(2));
  const Eigen::Vector2d d = p - scan.sensor_pose.head<2>();
  return Eigen::Vector2d(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
}

// --- 1. the local region (eq. 10, 7) -------------------------------------------------------------

// Eq. 7 / 10 are written for a 180 deg sensor: the half-plane x_s > margin. SensorModel::contains
// generalises them: for a wedge of 2a the signed distance to the nearer edge ray,
// sin(a) x - cos(a) |y|, must exceed the margin (exactly x_s at a = 90 deg); a polygon adds the
// distance to each of its edges; a minimum range is grown / shrunk like the maximum range.
void DjnnPaper::localRegion(const AssociationContext& ctx, LocalScan* scan) const {
  const double R = p_.sensor.max_range;
  // Spatial index first (O(cells + nearby)), then the exact eq. 10.
  scan->near = ctx.landmarksNear(scan->sensor_pose.head<2>(), R + p_.range_margin);
  std::sort(scan->near.begin(), scan->near.end());  // deterministic, whatever the index returns
  scan->cand.clear();
  scan->cand_valid.clear();
  const EkfSlam& ekf = ctx.ekf();
  for (int j : scan->near) {
    const Eigen::Vector2d ps = inSensorFrame(*scan, ekf.landmark(j));
    if (!inRegion(ps, p_.range_margin, p_.angle_margin * R)) continue;  // eq. 10
    scan->cand.push_back(j);
    scan->cand_valid.push_back(inRegion(ps, -p_.range_margin, -(p_.angle_margin * R)));  // eq. 7
  }
}

// --- 2. nearest neighbours (eq. 4-5) -------------------------------------------------------------

void DjnnPaper::nearestNeighbours(const AssociationContext& ctx, LocalScan* scan) const {
  const int m = scan->observations();
  for (int i = 0; i < m; ++i) {
    const int j = nearestNeighbour(ctx, i, scan->cand, gate_);
    if (j < 0) continue;
    scan->assign[i] = scan->slotOf(j);
    scan->gated[i] = 1;
  }
}

double DjnnPaper::score(const LocalScan& scan, int obs, int cand, const Eigen::Vector2d& v_bar,
                        double* mahalanobis) const {
  const AssociationContext::Individual& ind = scan.pair(obs, cand);
  const Eigen::Vector2d v = compensate(ind.v, v_bar, scan.kind[obs]);
  const double m = v.dot(ind.S_inv * v);
  *mahalanobis = m;
  return m + ind.log_det_S;  // eq. 5
}

int DjnnPaper::nearest(const LocalScan& scan, int obs, const Eigen::Vector2d& v_bar,
                       bool use_taken) const {
  int best = -1;
  double best_score = kInf;
  for (int c = 0; c < scan.candidates(); ++c) {
    if (use_taken && scan.taken[c]) continue;
    double m;
    const double sc = score(scan, obs, c, v_bar, &m);
    if (m <= gate_ && sc < best_score) {  // eq. 4, then eq. 5
      best_score = sc;
      best = c;
    }
  }
  return best;
}

void DjnnPaper::nearestAll(LocalScan* scan, const Eigen::Vector2d& v_bar) const {
  for (int i = 0; i < scan->observations(); ++i) scan->assign[i] = nearest(*scan, i, v_bar, false);
}

// --- 3. interference (cases 1-4, eq. 6-8) --------------------------------------------------------

Eigen::Vector2d DjnnPaper::meanInnovationOfUnique(const LocalScan& scan) const {
  // Eq. 6 over the pairs whose landmark no other observation claims.
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int p = 0;
  for (int i = 0; i < scan.observations(); ++i) {
    const int a = scan.assign[i];
    if (a < 0 || scan.count[a] != 1) continue;
    sum += scan.pair(i, a).v;
    ++p;
  }
  return p > 0 ? Eigen::Vector2d(sum / p) : Eigen::Vector2d::Zero();
}

void DjnnPaper::resolve(LocalScan* scan, const Eigen::Vector2d& v_bar, DjnnStats* stats) const {
  const int n = scan->candidates();
  const int m = scan->observations();
  std::vector<int>& winner = scan->winner;
  std::vector<double>& winner_score = scan->winner_score;
  // Every round hands each contested landmark to one observation and marks it taken; losers only
  // go to untaken landmarks, so the taken set grows every round: at most n rounds.
  for (int round = 0; round <= n; ++round) {
    if (scan->countPairings() == 0) return;
    ++stats->resolution_rounds;
    winner.assign(n, -1);
    winner_score.assign(n, kInf);
    for (int i = 0; i < m; ++i) {
      const int a = scan->assign[i];
      if (a < 0 || scan->count[a] < 2) continue;
      double mah;
      const double sc = score(*scan, i, a, v_bar, &mah);
      if (sc < winner_score[a]) {
        winner_score[a] = sc;
        winner[a] = i;
      }
    }
    for (int c = 0; c < n; ++c) scan->taken[c] = scan->count[c] > 0;
    for (int i = 0; i < m; ++i) {
      const int a = scan->assign[i];
      if (a < 0 || scan->count[a] < 2 || winner[a] == i) continue;
      scan->assign[i] = nearest(*scan, i, v_bar, true);
    }
  }
  scan->countPairings();
}

DjnnCase DjnnPaper::resolveInterference(const AssociationContext& ctx, LocalScan* scan,
                                        DjnnStats* stats) const {
  const int m = scan->observations();
  const int n = scan->candidates();
  const int contested = scan->countPairings();
  int paired = 0, unique = 0;
  for (int a : scan->assign) {
    if (a < 0) continue;
    ++paired;
    unique += scan->count[a] == 1;
  }
  const bool any_valid =
      std::find(scan->cand_valid.begin(), scan->cand_valid.end(), 1) != scan->cand_valid.end();
  scan->have_table = false;
  if (paired > 0 && contested == 0) return DjnnCase::kNoInterference;  // case 1
  if (paired == 0 && !any_valid) {
    ++stats->case4_accepted;  // case 4, nothing should have been seen (eq. 7): accept
    return DjnnCase::kNothingPaired;
  }
  // Cases 2-4 need every pair, compensated: compute them once.
  DjnnCase result;
  scan->have_table = true;
  scan->table.resize(static_cast<std::size_t>(m) * n);
  for (int i = 0; i < m; ++i) {
    for (int c = 0; c < n; ++c) {
      scan->table[static_cast<std::size_t>(i) * n + c] = ctx.individual(i, scan->cand[c]);
    }
  }
  scan->taken.assign(n, 0);
  Eigen::Vector2d v_bar = Eigen::Vector2d::Zero();
  if (paired == 0) {
    result = DjnnCase::kNothingPaired;  // case 4
    // Any landmark that should have been seen (eq. 7)? Then the closest pair within the wide
    // gate (eq. 8) measures the jump of the estimate.
    int bi = -1, bc = -1;
    double best = kInf;
    for (int c = 0; c < n; ++c) {
      if (!scan->cand_valid[c]) continue;
      for (int i = 0; i < m; ++i) {
        const double mah = scan->pair(i, c).mahalanobis;
        if (mah <= wide_gate_ && mah < best) {
          best = mah;
          bi = i;
          bc = c;
        }
      }
    }
    if (bi < 0) {
      ++stats->case4_accepted;
    } else {
      ++stats->case4_compensated;
      v_bar = scan->pair(bi, bc).v;
      nearestAll(scan, v_bar);
      resolve(scan, v_bar, stats);
    }
  } else if (unique > 0) {
    result = DjnnCase::kPartial;  // case 2
    v_bar = meanInnovationOfUnique(*scan);
    resolve(scan, v_bar, stats);
  } else {
    result = DjnnCase::kAllInterfere;  // case 3
    // Each contested landmark keeps its closest observation (eq. 5, uncompensated); their mean
    // innovation (eq. 6 over these q pairs) compensates all m observations, then NN again.
    std::vector<int>& winner = scan->winner;
    std::vector<double>& winner_score = scan->winner_score;
    winner.assign(n, -1);
    winner_score.assign(n, kInf);
    const Eigen::Vector2d zero = Eigen::Vector2d::Zero();
    for (int i = 0; i < m; ++i) {
      const int a = scan->assign[i];
      if (a < 0) continue;
      double mah;
      const double sc = score(*scan, i, a, zero, &mah);
      if (sc < winner_score[a]) {
        winner_score[a] = sc;
        winner[a] = i;
      }
    }
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int q = 0;
    for (int c = 0; c < n; ++c) {
      if (winner[c] < 0) continue;
      sum += scan->pair(winner[c], c).v;
      ++q;
    }
    v_bar = sum / q;  // q >= 1: at least one landmark is contested
    nearestAll(scan, v_bar);
    resolve(scan, v_bar, stats);
  }
  scan->v_bar = v_bar;
  return result;
}

// --- 4a. evidence of the map landmarks (eq. 9) ---------------------------------------------------

void DjnnPaper::countMapEvidence(const AssociationContext& ctx, const LocalScan& scan,
                                 AssociationResult* result, DjnnStats* stats) {
  const EkfSlam& ekf = ctx.ekf();
  // Only the local region is visited: a landmark outside it cannot be inside the sensor region,
  // so its r_k is 0 anyway.
  for (int k = 0; k < scan.candidates(); ++k) {
    const LandmarkId id = ctx.landmarkId(scan.cand[k]);
    if (std::find(result->remove.begin(), result->remove.end(), id) != result->remove.end()) {
      continue;  // removed already (the bias test)
    }
    auto it = evidence_.try_emplace(id, p_.initial_evidence).first;
    double r = 0.0;
    if (scan.count[k] > 0) {
      r = model_.step(true, ekf.landmarkCovariance(scan.cand[k]), scan.detectableAt(k));
    } else {
      const Eigen::Vector2d ps = inSensorFrame(scan, ekf.landmark(scan.cand[k]));
      // A scan the joint decision held undecided says nothing about which landmark was missed;
      // a landmark the scan shows hidden (the occlusion extension) was out of view.
      if (!scan.held && inPenaltyRegion(ps)) {
        if (scan.isHidden(k)) {
          ++stats->hidden_misses;
        } else {
          r = model_.step(false, ekf.landmarkCovariance(scan.cand[k]), scan.detectableAt(k));
        }
      }
    }
    it->second += r;
    if (it->second <= p_.remove_evidence + kEvidenceEps) {
      result->remove.push_back(id);
      evidence_.erase(it);
      ++stats->removed;
    }
  }
  // Counters of landmarks removed by someone else: swept when they could dominate (amortised).
  if (evidence_.size() > 2 * ekf.numLandmarks() + 64) {
    for (auto it = evidence_.begin(); it != evidence_.end();) {
      it = ekf.contains(it->first) ? std::next(it) : evidence_.erase(it);
    }
  }
}

// --- 4b. evidence of the features not in the map (eq. 9) -----------------------------------------

int DjnnPaper::startFeature(const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                            const Eigen::Vector2d& heading_lever, FeatureRules* rules,
                            double detectable) {
  const int slot = tentatives_.add(z);
  restartFeature(slot, z, C, stamp, heading_lever, rules, detectable);
  return slot;
}

void DjnnPaper::restartFeature(int slot, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                               double stamp, const Eigen::Vector2d& heading_lever,
                               FeatureRules* rules, double detectable) {
  Tentative& t = tentatives_[slot];
  // A new run of sightings: the earlier ones of a restarted feature no longer count.
  const FeatureKey earlier = t.key;
  t.key = next_key_++;
  if (earlier != kNoFeature) restarted_.emplace_back(earlier, t.key);
  t.cov = C;
  t.heading_lever = heading_lever;
  t.evidence = model_.step(true, C, detectable);  // seen now
  t.last_seen = stamp;
  t.sightings = 1;
  t.residual = 0.0;
  t.first_seen = stamp;
  t.track_info.setZero();
  t.track_vec.setZero();
  rules->started(&t, z, C, stamp);
  tentatives_.move(slot, z);
}

void DjnnPaper::dropFeature(const AssociationContext& ctx, int slot, bool stale,
                            FeatureRules* rules) {
  Tentative& t = tentatives_[slot];
  if (!t.alive) return;
  rules->dropping(ctx, slot, stale);
  ended_.push_back(t.key);
  t.key = kNoFeature;
  tentatives_.remove(slot);
}

Eigen::Matrix2d DjnnPaper::sightingGate(const AssociationContext& ctx, int obs,
                                        const Eigen::Vector3d& pose, const Eigen::Matrix3d& P_vv,
                                        const FeatureRules& rules, Sighting* s, double* lever_var) {
  const Observation& o = ctx.observations()[obs];
  Matrix23d G_pose;
  s->pos = ctx.sightingPosition(pose, o.z, o.R, o.kind, &G_pose, &s->cov_obs);
  s->heading_lever = G_pose.col(2);
  // Gate on position: observation noise of both sightings plus the current pose covariance once
  // (an upper bound on the pose error accumulated between the sightings; using it twice would
  // double-count the correlated part).
  return rules.gateCovariance(s->cov_obs, G_pose, P_vv, lever_var);
}

namespace {

// Far returns seen with coarse bearings (second_order_observations): from where it was taken, a
// return is precise in range and known only to tens of metres across, a banana in the map frame.
// Fused and gated as Gaussians there, the sightings on the arc pull the feature off it by
// range sigma_b^2 / 2, several sd of the range noise, and the gate turns away the feature's own
// sightings. Such a feature is kept in anchored polar form instead (range and world bearing from
// the sensor position of its first sighting, where it is Gaussian) and updated like a landmark.
bool inPolar(const AssociationContext& ctx, int obs) {
  return ctx.ekf().secondOrderObservations() &&
         ctx.observations()[obs].kind == MeasurementKind::kRangeBearing;
}

// The map-frame point of t's polar form and J = d point / d (range, bearing).
Eigen::Vector2d polarPoint(const Tentative& t, Eigen::Matrix2d* J) {
  const double rho = t.polar_y(0), phi = t.polar_y(1);
  const Eigen::Vector2d u(std::cos(phi), std::sin(phi));
  *J << u(0), -rho * u(1), u(1), rho * u(0);
  return t.polar_origin + rho * u;
}

// t's mean and covariance in the map frame from its polar form, with the second-order terms of
// the polar form's spread (what the static test, the index and the other rules read).
void syncPolar(Tentative* t, Eigen::Vector2d* position) {
  Eigen::Matrix2d J, extra;
  Eigen::Vector2d mean;
  const Eigen::Vector2d p = polarPoint(*t, &J);
  RangeBearingModel::polarSecondOrder(t->polar_y(0), t->polar_y(1), t->polar_cov, &mean, &extra);
  *position = p + mean;
  t->cov = J * t->polar_cov * J.transpose() + extra;
  t->cov = 0.5 * (t->cov + t->cov.transpose()).eval();
}

// The sighting's innovation against t's polar form, its covariance (the pose part C_pose in the
// map frame added), and H_y = d z / d (range, bearing), H_p = d z / d point.
void polarFormInnovation(const AssociationContext& ctx, int obs, const Tentative& t,
                         const Eigen::Matrix2d& C_pose, Eigen::Vector2d* v, Eigen::Matrix2d* S,
                         Eigen::Matrix2d* H_y, Eigen::Matrix2d* H_p, Eigen::Matrix2d* J) {
  const Observation& o = ctx.observations()[obs];
  const Eigen::Vector2d p = polarPoint(t, J);
  const Eigen::Vector2d z_hat = ctx.model().predict(ctx.robotPose(), p, nullptr, H_p);
  *H_y = *H_p * *J;
  *v = RangeBearingModel::innovation(o.z, z_hat);
  *S = *H_y * t.polar_cov * H_y->transpose() + *H_p * C_pose * H_p->transpose() + o.R;
}

}  // namespace

void DjnnPaper::startPolar(const AssociationContext& ctx, int obs, int slot) {
  Tentative& t = tentatives_[slot];
  t.polar = inPolar(ctx, obs);
  if (!t.polar) return;
  // Seen from one place a far return is precise in range and known only across: in polar form
  // about that place it is Gaussian, where in the map frame it is a banana.
  const Observation& o = ctx.observations()[obs];
  const Eigen::Vector3d sensor = ctx.sensorPose();
  t.polar_origin = sensor.head<2>();
  t.polar_y << o.z(0), sensor(2) + o.z(1);
  t.polar_cov = o.R;
  Eigen::Vector2d position;
  syncPolar(&t, &position);
  tentatives_.move(slot, position);
}

double DjnnPaper::tentativeDistance2(const AssociationContext& ctx, int obs, const Sighting& s,
                                     const Eigen::Matrix2d& C, double lever_var,
                                     const Tentative& t) {
  // A heading error common to both moves each by its lever: they differ by the change of lever.
  const Eigen::Vector2d dl = s.heading_lever - t.heading_lever;
  const Eigen::Matrix2d lever = lever_var * dl * dl.transpose();
  if (inPolar(ctx, obs) && t.polar) {
    Eigen::Vector2d v;
    Eigen::Matrix2d S, H_y, H_p, J;
    polarFormInnovation(ctx, obs, t, (C - s.cov_obs) + lever, &v, &S, &H_y, &H_p, &J);
    return v.dot(S.inverse() * v);
  }
  const Eigen::Matrix2d S = C + t.cov + lever;
  const Eigen::Vector2d e = s.pos - t.position;
  return e.dot(S.inverse() * e);
}

Eigen::Vector2d DjnnPaper::fuseSighting(const AssociationContext& ctx, int obs, const Sighting& s,
                                        const Eigen::Matrix2d& C, Tentative* t) {
  Eigen::Matrix2d K_map;  // d fused / d sighting's point: how the heading lever is fused
  Eigen::Vector2d fused;
  if (inPolar(ctx, obs) && t->polar) {
    Eigen::Vector2d v;
    Eigen::Matrix2d S, H_y, H_p, J;
    polarFormInnovation(ctx, obs, *t, Eigen::Matrix2d::Zero(), &v, &S, &H_y, &H_p, &J);
    const Eigen::Matrix2d K = t->polar_cov * H_y.transpose() * S.inverse();
    const Eigen::Matrix2d I_KH = Eigen::Matrix2d::Identity() - K * H_y;
    const Eigen::Matrix2d R_eff = S - H_y * t->polar_cov * H_y.transpose();
    t->polar_y += K * v;
    t->polar_cov = I_KH * t->polar_cov * I_KH.transpose() + K * R_eff * K.transpose();
    t->polar_cov = 0.5 * (t->polar_cov + t->polar_cov.transpose()).eval();
    K_map = J * K * H_p;
    syncPolar(t, &fused);  // sets t->cov
  } else {
    // Information-weighted on their observation noise.
    K_map = t->cov * (t->cov + C).inverse();
    fused = t->position + K_map * (s.pos - t->position);
    t->cov = (Eigen::Matrix2d::Identity() - K_map) * t->cov;
    t->cov = 0.5 * (t->cov + t->cov.transpose()).eval();
  }
  t->heading_lever += K_map * (s.heading_lever - t->heading_lever);
  return fused;
}

void DjnnPaper::countFeatureEvidence(const AssociationContext& ctx, LocalScan* scan,
                                     AssociationResult* result, FeatureRules* rules,
                                     DjnnStats* stats) {
  const int m = static_cast<int>(ctx.numObservations());
  const double stamp = ctx.stamp();
  const Eigen::Vector3d pose = ctx.robotPose();
  const Eigen::Matrix3d P_vv = ctx.ekf().poseCovariance();
  tentatives_.query(scan->sensor_pose.head<2>(), p_.sensor.max_range + p_.range_margin,
                    &tent_near_);
  tent_hit_.assign(tent_near_.size(), 0);

  // Observations that may be a feature not yet in the map: unpaired, not ambiguous, inside the
  // effective range (beyond R nothing can be paired, so they would only duplicate landmarks).
  std::vector<Sighting>& seen = sightings_;
  seen.assign(m, Sighting{Eigen::Vector2d::Zero(), Eigen::Matrix2d::Zero(), Eigen::Vector2d::Zero(),
                          -1, false});
  std::vector<TentativePair>& pairs = tentative_pairs_;
  pairs.clear();
  // Pairs outside the tentative gate but within the rules' wider one (withheld below).
  const double withhold = rules->withholdGate();
  std::vector<TentativePair>& wide = tentative_wide_;
  wide.clear();
  for (int i = 0; i < m; ++i) {
    const Observation& o = ctx.observations()[i];
    if (result->decision[i] == Decision::kPaired || scan->gated[i]) continue;
    if (!(RangeBearingModel::range(o.z, o.kind) < p_.sensor.max_range) || !o.z.allFinite()) {
      continue;
    }
    seen[i].eligible = true;
    seen[i].detectable = rules->detectable(ctx, RangeBearingModel::range(o.z, o.kind));
    double lever_var = 0.0;
    const Eigen::Matrix2d C = sightingGate(ctx, i, pose, P_vv, *rules, &seen[i], &lever_var);
    for (int k = 0; k < static_cast<int>(tent_near_.size()); ++k) {
      const double d2 =
          tentativeDistance2(ctx, i, seen[i], C, lever_var, tentatives_[tent_near_[k]]);
      if (d2 <= tentative_gate_) {
        pairs.push_back({d2, i, k});
      } else if (d2 <= withhold) {
        wide.push_back({d2, i, k});
      }
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
    Tentative& t = tentatives_[slot];
    const Eigen::Vector2d& z = seen[cnd.obs].pos;
    const Eigen::Matrix2d& C = seen[cnd.obs].cov_obs;
    if (!rules->stillStatic(ctx, cnd.obs, &t, seen[cnd.obs], C, stamp)) {
      // Not one static point (a slow mover): its history is void; restart from this sighting.
      restartFeature(slot, z, C, stamp, seen[cnd.obs].heading_lever, rules,
                     seen[cnd.obs].detectable);
      startPolar(ctx, cnd.obs, slot);
      ++stats->static_restarts;
      continue;
    }
    const Eigen::Vector2d fused = fuseSighting(ctx, cnd.obs, seen[cnd.obs], C, &t);
    t.evidence += model_.step(true, t.cov, seen[cnd.obs].detectable);
    t.last_seen = stamp;
    tentatives_.move(slot, fused);
  }

  // A sighting paired with no feature but within the wider gate of one left unpaired may be that
  // feature's, a little off: it neither starts a second feature nor counts as the first's miss
  // (FeatureRules::withholdGate; the paper has none).
  tent_withheld_.assign(tent_near_.size(), 0);
  obs_withheld_.assign(m, 0);
  for (const TentativePair& w : wide) {
    if (seen[w.obs].slot >= 0 || tent_hit_[w.local]) continue;
    tent_withheld_[w.local] = 1;
    obs_withheld_[w.obs] = 1;
  }
  for (int i = 0; i < m; ++i) stats->tentative_withheld += obs_withheld_[i];

  // Tentative features in the region that were not seen this scan: r_k = -1 inside the sensor
  // region, 0 outside (eq. 9); stale ones time out.
  for (int k = 0; k < static_cast<int>(tent_near_.size()); ++k) {
    if (tent_hit_[k]) continue;
    const int slot = tent_near_[k];
    Tentative& t = tentatives_[slot];
    const Eigen::Vector2d ps = inSensorFrame(*scan, t.position);
    if (inPenaltyRegion(ps) && !tent_withheld_[k]) {
      const double detectable = rules->detectable(ctx, ps.norm());
      t.evidence += model_.step(false, t.cov, detectable);
    }
    const bool stale = p_.tentative_timeout > 0.0 && stamp - t.last_seen > p_.tentative_timeout;
    if (t.evidence <= p_.remove_evidence + kEvidenceEps || stale) {
      dropFeature(ctx, slot, stale && t.evidence > p_.remove_evidence + kEvidenceEps, rules);
      ++stats->tentative_dropped;
    }
  }

  // Decisions: admitted when T reaches the admission threshold (eq. 9), else tentative.
  for (int i = 0; i < m; ++i) {
    if (!seen[i].eligible || obs_withheld_[i]) continue;  // withheld: kRejected this scan
    int slot = seen[i].slot;
    const bool born = slot < 0;
    if (born) {
      slot = startFeature(seen[i].pos, seen[i].cov_obs, stamp, seen[i].heading_lever, rules,
                          seen[i].detectable);
      startPolar(ctx, i, slot);
    }
    rules->sighted(ctx, slot, i, born);
    const double t = tentatives_[slot].evidence;
    result->decision[i] = rules->decide(ctx, i, slot, t, t >= p_.admit_evidence - kEvidenceEps);
    result->feature[i] = tentatives_[slot].key;
    if (result->decision[i] == Decision::kNew) {
      // Now the pipeline's landmark; its T in landmarkAdded().
      dropFeature(ctx, slot, false, rules);
      ++stats->admitted;
    }
  }

  // Amortised timeout sweep over the whole tentative set (features the robot never revisits).
  // Not the paper's: it also reports the features out of the sensor's reach (beyond its range by
  // more than the margin), whose sightings the pipeline may then let go: the vehicle must drive
  // back before it can see them again, where turning would do for one merely out of the wedge.
  const double reach = p_.sensor.max_range + p_.range_margin;
  for (std::size_t n = 0; n < kSweepPerScan && n < tentatives_.slots(); ++n) {
    const int slot = tentatives_.nextSweepSlot();
    const Tentative& t = tentatives_[slot];
    if (!t.alive) continue;
    if (p_.tentative_timeout > 0.0 && stamp - t.last_seen > p_.tentative_timeout) {
      dropFeature(ctx, slot, true, rules);
      ++stats->tentative_dropped;
    } else if ((t.position - scan->sensor_pose.head<2>()).norm() > reach) {
      result->out_of_reach_features.push_back(t.key);
    }
  }
  result->ended_features.insert(result->ended_features.end(), ended_.begin(), ended_.end());
  ended_.clear();
  result->restarted_features.insert(result->restarted_features.end(), restarted_.begin(),
                                    restarted_.end());
  restarted_.clear();
}

}  // namespace ekf_slam
