// DJNN: the paper's steps (djnn_paper.h) with the extensions' calls between them. See djnn.h and
// docs/djnn.md.
#include "ekf_slam/core/association/djnn/djnn.h"

#include "ekf_slam/core/association/djnn/missed_detection_profile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

namespace ekf_slam {

namespace {
constexpr int kMaxEvidence = 1000000;

// Whether the source gives `name` (a number): set with a wrong type counts, read() says so.
bool isSet(const ParameterSource& source, const std::string& name) {
  try {
    double value;
    return source.get(name, &value);
  } catch (const std::invalid_argument&) {
    return true;
  }
}

// A part's parameters as `r` gives them.
template <class Part>
typename Part::Params paramsOf(const ParameterReader& r) {
  Part part;
  part.read(r);
  return part.params();
}
}  // namespace

DJNN::DJNN() {
  // Usable without configure() (tests, tools): the documented defaults.
  configure(MapParameterSource());
}

void DJNN::configure(const ParameterSource& user) {
  // A sensor that misses landmarks gets the missed-detection profile's defaults under the user's
  // values (missed_detection_profile.h).
  DjnnPaperParams paper;
  paper.read(ParameterReader(user));
  const ParameterDefaults profiled(user, missedDetectionDefaults());
  const bool profile = ParameterReader(user).flag("missed_detection_profile", true);
  const bool misses = profile && paper.sensor.detection_probability < 1.0;
  // A P_D the user did not give is estimated online; the profile then waits for the estimate.
  const bool estimate_pd = profile && !isSet(user, "detection_probability");
  const ParameterSource& params = misses ? static_cast<const ParameterSource&>(profiled) : user;
  // Every part reads its own parameters; nothing changes unless all of them are valid.
  const ParameterReader r(params);
  Params p;
  AmbiguityGate ambiguity;
  ambiguity.read(r, paper.individual_probability);
  StaticTest static_test;
  static_test.read(r);
  MoverSpeed mover_speed;
  mover_speed.read(r);
  FollowPose follow_pose;
  follow_pose.read(r);
  DensityTest density;
  density.read(r);
  JointDecision joint;
  joint.read(r,
             density.params().landmark_density > 0.0 || density.estimating() ||
                 paper.sensor.clutter_density > 0.0,
             isSet(params, "loop_closure_age"));
  RememberedFeatures remembered;
  remembered.read(r);
  LandmarkSpacing spacing;
  spacing.read(r, paper.sensor.clutter_density);
  HeldConfirmation confirmation;
  confirmation.read(r);
  BiasTest bias;
  bias.read(r);
  OccludedMisses occlusion;
  occlusion.read(r, paper.individual_probability);
  OptimalAssignment assignment;
  assignment.read(r);
  BeamSpacingMisses beam_spacing;
  beam_spacing.read(r);
  HeldSightings held_sightings;
  held_sightings.read(r);
  UnmappedReturns unmapped;
  unmapped.read(r);
  DetectionEstimate detection;
  detection.read(r);

  p.paper = paper;
  p.ambiguity = ambiguity.params();
  p.static_test = static_test.params();
  p.mover_speed = mover_speed.params();
  p.bias = bias.params();
  p.follow_pose = follow_pose.params();
  p.density = density.params();
  p.joint = joint.params();
  p.remembered = remembered.params();
  p.spacing = spacing.params();
  p.confirmation = confirmation.params();
  p.occlusion = occlusion.params();
  p.assignment = assignment.params();
  p.beam_spacing = beam_spacing.params();
  p.held_sightings = held_sightings.params();
  p.unmapped = unmapped.params();
  p.detection = detection.params();
  // The profiled parts' parameters, for the switch when the estimate shows misses.
  Profiled q{p.static_test, p.mover_speed, p.follow_pose, p.density,
             p.bias,        p.remembered,  p.confirmation};
  if (estimate_pd) {
    const ParameterReader pr(profiled);
    q.static_test = paramsOf<StaticTest>(pr);
    q.mover_speed = paramsOf<MoverSpeed>(pr);
    q.follow_pose = paramsOf<FollowPose>(pr);
    q.density = paramsOf<DensityTest>(pr);
    q.bias = paramsOf<BiasTest>(pr);
    q.remembered = paramsOf<RememberedFeatures>(pr);
    q.confirmation = paramsOf<HeldConfirmation>(pr);
  }
  p_ = p;
  profiled_ = q;
  ambiguity_ = ambiguity;
  static_test_ = static_test;
  mover_speed_ = mover_speed;
  follow_pose_ = follow_pose;
  density_test_ = density;
  joint_ = joint;
  remembered_ = remembered;
  spacing_ = spacing;
  confirmation_ = confirmation;
  bias_test_ = bias;
  occlusion_ = occlusion;
  assignment_ = assignment;
  beam_spacing_ = beam_spacing;
  held_sightings_ = held_sightings;
  unmapped_ = unmapped;
  detection_ = detection;
  detection_.configure(estimate_pd);

  paper_.configure(p_.paper);
  density_test_.configure(p_.paper.sensor);
  unmapped_.configure(density_test_.regionArea());
  static_test_.configure(p_.paper.admit_evidence, mover_speed_.on(), p_.paper.tentative_timeout);
  mover_speed_.configure(p_.paper.tentative_timeout);
  bias_test_.configure();
  reset();
}

void DJNN::missesDetected(AssociationResult* result) {
  p_.static_test = profiled_.static_test;
  p_.mover_speed = profiled_.mover_speed;
  p_.follow_pose = profiled_.follow_pose;
  p_.density = profiled_.density;
  p_.bias = profiled_.bias;
  p_.remembered = profiled_.remembered;
  p_.confirmation = profiled_.confirmation;
  static_test_.setParams(p_.static_test);
  mover_speed_.setParams(p_.mover_speed);
  follow_pose_.setParams(p_.follow_pose);
  density_test_.setParams(p_.density);
  bias_test_.setParams(p_.bias);
  remembered_.setParams(p_.remembered);
  confirmation_.setParams(p_.confirmation);
  static_test_.configure(p_.paper.admit_evidence, mover_speed_.on(), p_.paper.tentative_timeout);
  bias_test_.configure();
  result->notice = detection_.notice();
}

// The detection estimate is kept: the sensor is the same one.
void DJNN::reset() {
  paper_.reset();
  static_test_.reset();
  mover_speed_.reset();
  bias_test_.reset();
  joint_.reset();
  density_test_.reset();
  unmapped_.reset();
  remembered_.reset();
  confirmation_.clear();
  scan_ = LocalScan();
  pending_new_.clear();
  last_case_ = Case::kNone;
  stats_ = Stats();
}

AssociationResult DJNN::associate(const AssociationContext& ctx) {
  const int m = static_cast<int>(ctx.numObservations());
  AssociationResult result;
  result.resize(m);
  pending_new_.assign(m, -1);
  mover_speed_.beginScan(m);
  scan_.force_new.assign(m, 0);
  scan_.held = false;
  scan_.v_bar.setZero();
  if (m == 0) {
    // The paper calls DJNN only for non-empty scans (seed 000 section 5.2: 6949 non-empty scans,
    // 6948 calls), so an empty scan changes no counter.
    last_case_ = Case::kNone;
    return result;
  }
  ++stats_.scans;
  scan_.stamp = ctx.stamp();
  scan_.sensor_pose = ctx.sensorPose();
  scan_.kind.resize(m);
  for (int i = 0; i < m; ++i) scan_.kind[i] = ctx.observations()[i].kind;

  // The paper: local region (eq. 10), NN (eq. 4-5), interference (cases 1-4, eq. 6-8).
  paper_.localRegion(ctx, &scan_);
  scan_.assign.assign(m, -1);
  scan_.gated.assign(m, 0);
  paper_.nearestNeighbours(ctx, &scan_);
  density_test_.observe(ctx, paper_, scan_);
  last_case_ = paper_.resolveInterference(ctx, &scan_, &stats_);
  ++stats_.cases[static_cast<int>(last_case_)];
  // "Not in the map", for the assignment, the joint decision and the density test alike: a
  // landmark the map does not hold yet, or clutter, per m^2 (UnmappedReturns: measured where the
  // map is).
  const double clutter = p_.paper.sensor.clutter_density;
  const double unmapped_prior = density_test_.density() + clutter;
  const double null_cost = -2.0 * std::log(unmapped_.density(unmapped_prior));
  // Without a density of "not in the map" yet (an estimate before any mapped landmark was in
  // view), nothing weighs a pairing against it.
  const bool unmapped_known = unmapped_prior > 0.0;
  // The same pairings, exchanged where that fits them better jointly.
  assignment_.apply(ctx, paper_,
                    unmapped_known ? null_cost : std::numeric_limits<double>::infinity(), &scan_,
                    &stats_);

  // Extensions on the pairing: unpaired but ambiguous observations make no feature; at a loop
  // closure the joint decision weighs every hypothesis the density test weighs, the scan shifted
  // onto gated neighbours included, and more.
  ambiguity_.apply(ctx, paper_, &scan_);
  const JointDecision::Parts parts{
      paper_, ambiguity_.gate(), null_cost, clutter, spacing_, remembered_, confirmation_,
  };
  // Without it the joint decision has no null hypothesis: the scan is decided as without it.
  if (!joint_.on() || !unmapped_known || !joint_.decide(ctx, parts, &scan_, &stats_)) {
    density_test_.apply(ctx, null_cost, &scan_, &stats_);
    unmapped_.observe(ctx, scan_, p_.paper.sensor.max_range);
  }
  scan_.countPairings();
  for (int i = 0; i < m; ++i) {
    if (scan_.assign[i] >= 0) result.pair(i, ctx.landmarkId(scan_.cand[scan_.assign[i]]));
  }

  // The paper's evidence (eq. 9), of the map's landmarks (after the bias test withdrew the
  // pairings of landmarks that follow a mover) and of the features not in the map.
  bias_test_.test(ctx, &scan_, &result, &paper_, &stats_);
  const std::size_t removed_before = result.remove.size();
  occlusion_.mark(ctx, &scan_);
  beam_spacing_.mark(ctx, &scan_);
  // A P_D not set is measured on the map's landmarks; once they show that the sensor misses
  // them, the profile comes on and the evidence counts with the estimate.
  if (detection_.observe(ctx, paper_, scan_, result)) missesDetected(&result);
  if (detection_.switched()) paper_.setDetectionProbability(detection_.estimate());
  paper_.countMapEvidence(ctx, scan_, &result, &stats_);
  for (std::size_t k = removed_before; k < result.remove.size(); ++k)
    bias_test_.forget(result.remove[k]);
  bias_test_.sweep(ctx.ekf());
  static_test_.beginScan(ctx.ekf().poseCovariance());
  held_sightings_.join(ctx, scan_, this, &paper_, &result, &stats_);
  paper_.countFeatureEvidence(ctx, &scan_, &result, this, &stats_);
  static_test_.endRestartedRuns(&result);

  mover_speed_.scanDone(ctx, result, paper_, scan_, p_.paper.admit_evidence, static_test_);
  static_test_.useLearnedSpeed(mover_speed_.speed());
  if (joint_.on()) {
    joint_.record(result, scan_.stamp);
    for (LandmarkId id : result.remove) remembered_.forgetAnchor(id);  // their anchor is gone
  }
  return result;
}

// --- the extensions' share of the tentative-feature step -----------------------------------------

Eigen::Matrix2d DJNN::gateCovariance(const Eigen::Matrix2d& cov_obs, const Matrix23d& G_pose,
                                     const Eigen::Matrix3d& P_vv, double* lever_var) const {
  return follow_pose_.gateCovariance(cov_obs, G_pose, P_vv, lever_var);
}

bool DJNN::stillStatic(const AssociationContext& ctx, int obs, Tentative* t, const Sighting& s,
                       const Eigen::Matrix2d& C, double stamp) {
  return static_test_.stillStatic(t, s.pos, s.heading_lever, C, stamp, &ctx, obs);
}

void DJNN::started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp) {
  static_test_.started(t, z, C, stamp);
  t->history.clear();
  t->chance_failure = false;
}

void DJNN::dropping(const AssociationContext& ctx, int slot, bool stale) {
  if (!stale) return;
  remembered_.timedOut(ctx, paper_.tentatives()[slot],
                       p_.paper.sensor.max_range + p_.paper.range_margin, paper_.tentativeGate(),
                       &stats_);
}

void DJNN::sighted(const AssociationContext& ctx, int slot, int obs, bool born) {
  Tentative& t = paper_.tentatives()[slot];
  if (born) t.held_birth = scan_.force_new[obs] == kForceHeld;
  static_test_.record(ctx, obs, &t);
  remembered_.anchor(
      ctx, scan_, &t, [this](LandmarkId id) { return joint_.recentlyPaired(id, scan_.stamp); },
      paper_.tentativeGate());
}

Decision DJNN::decide(const AssociationContext& ctx, int obs, int slot, double evidence,
                      bool paper_admits) {
  const char force = scan_.force_new[obs];
  const Tentative& t = paper_.tentatives()[slot];
  // The paper's evidence, or where no mover is seen enough static sightings (static_test.h).
  const bool evidence_admits = paper_admits || static_test_.admitsOnSightings(t);
  const bool static_ok =
      static_test_.admits(t) && !(evidence_admits && static_test_.movingAtAdmission(ctx, t, obs));
  const bool admitting =
      force == kForceAdmit || (force != kForceHeld && evidence_admits && static_ok);
  if (admitting && spacing_.within(ctx, obs, scan_.cand, paper_.gate())) {
    ++stats_.spacing_refused;
    return Decision::kTentative;
  }
  if (force == kForceHeld) return Decision::kTentative;
  if (force == kForceAdmit) {
    // On a remembered feature (joint decision).
    pending_new_[obs] = std::max(evidence, static_cast<double>(p_.paper.admit_evidence));
    ++stats_.remembered_admitted;
    return Decision::kNew;
  }
  if (evidence_admits && static_ok) {
    pending_new_[obs] = evidence;
    mover_speed_.admitting(obs, t, static_test_);
    return Decision::kNew;
  }
  return Decision::kTentative;
}

// --- hooks of the pipeline -----------------------------------------------------------------------

void DJNN::landmarkAdded(int obs, LandmarkId id) {
  double t = p_.paper.admit_evidence;
  if (obs >= 0 && obs < static_cast<int>(pending_new_.size()) && pending_new_[obs] >= 0) {
    t = pending_new_[obs];
  }
  paper_.setEvidence(id, t);
  if (joint_.on()) joint_.landmarkAdded(id, scan_.stamp);
  mover_speed_.landmarkAdded(obs, id);
}

void DJNN::poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) {
  follow_pose_.poseCorrected(prior, posterior, p_.paper.sensor.max_range + p_.paper.range_margin,
                             &paper_.tentatives());
}

void DJNN::landmarkLoaded(LandmarkId id, std::uint32_t times_observed) {
  // A saved landmark was confirmed that many times: it survives as many misses (the evidence it
  // would have had with no miss), at least the admission level.
  long t = std::max<long>(
      {static_cast<long>(times_observed), p_.paper.admit_evidence, p_.paper.initial_evidence});
  paper_.setEvidence(id, static_cast<double>(std::min<long>(t, kMaxEvidence)));
}

bool DJNN::landmarkFromLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                                 const std::vector<LostLook>& looks) {
  // The paper's evidence (eq. 9) over the lost scans, as tracking would have counted it had the
  // pose been known: a feature from its first sighting, admitted at admit_evidence, dropped or
  // removed at remove_evidence (then started again by its next sighting); misses count inside
  // the penalty region. Kept when it ends admitted, with that evidence.
  const EvidenceModel& model = paper_.evidenceModel();
  const double eps = 1e-9;
  bool alive = false, admitted = false;
  double t = 0.0;
  for (const LostLook& l : looks) {
    if (l.seen) {
      const double r = model.step(true, cov);
      t = alive ? t + r : r;
      alive = true;
      admitted = admitted || t >= p_.paper.admit_evidence - eps;
    } else if (alive && paper_.inPenaltyRegion(l.in_sensor)) {
      t += model.step(false, cov);
      if (t <= p_.paper.remove_evidence + eps) alive = admitted = false;
    }
  }
  if (!(alive && admitted)) return false;
  paper_.setEvidence(id, t);
  return true;
}

bool DJNN::landmarkOverLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                                 const std::vector<LostLook>& looks) {
  // Its evidence (eq. 9) carried on over the lost scans, as tracking would have counted it.
  const EvidenceModel& model = paper_.evidenceModel();
  double t = paper_.evidenceValue(id);
  for (const LostLook& l : looks) {
    if (l.seen) {
      t += model.step(true, cov);
    } else if (paper_.inPenaltyRegion(l.in_sensor)) {
      t += model.step(false, cov);
    } else {
      continue;
    }
    if (t <= p_.paper.remove_evidence + 1e-9) {
      paper_.forget(id);
      return false;
    }
  }
  paper_.setEvidence(id, t);
  return true;
}

std::vector<TentativeFeature> DJNN::tentativeFeatures() const {
  std::vector<TentativeFeature> out;
  const TentativeSet& set = paper_.tentatives();
  for (std::size_t s = 0; s < set.slots(); ++s) {
    const Tentative& t = set[static_cast<int>(s)];
    if (t.alive) out.push_back({t.position, static_cast<int>(std::floor(t.evidence + 1e-9))});
  }
  return out;
}

}  // namespace ekf_slam
