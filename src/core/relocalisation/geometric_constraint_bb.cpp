// Geometric-constraint branch and bound, shared by FGCBB and GCBB. See geometric_constraint_bb.h.
#include "ekf_slam/core/relocalisation/geometric_constraint_bb.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

namespace {

RelocalisationResult notFound(RelocalisationResult r, const std::string& reason,
                              RelocalisationStatus status = RelocalisationStatus::kNotFound) {
  r.status = status;
  r.reason = reason;
  return r;
}

}  // namespace

GeometricConstraintBB::GeometricConstraintBB(const GeometricConstraintParams& defaults)
    : defaults_(defaults), params_(defaults) {
  configure(MapParameterSource());
}

void GeometricConstraintBB::configure(const ParameterSource& source) {
  const ParameterReader r(source);
  const GeometricConstraintParams& d = defaults_;
  GeometricConstraintParams p;
  p.sensor_range = r.positive("sensor_range", d.sensor_range);
  p.max_observation_range = r.nonNegative("max_observation_range", d.max_observation_range);
  p.group_size = r.integer("group_size", d.group_size, 0, 30);
  p.overlapping_groups = r.flag("overlapping_groups", d.overlapping_groups);
  p.group_coverage = r.integer("group_coverage", d.group_coverage, 0, 30);
  p.use_locality = r.flag("use_locality", d.use_locality);
  p.unary_probability = r.probability("unary_probability", d.unary_probability);
  p.descriptor_sigma = r.positive("descriptor_sigma", d.descriptor_sigma);
  p.range_sigma = r.nonNegative("range_sigma", d.range_sigma);
  p.bearing_sigma = r.nonNegative("bearing_sigma", d.bearing_sigma);
  p.landmark_sigma_cap = r.nonNegative("landmark_sigma_cap", d.landmark_sigma_cap);
  p.binary_probability = r.probability("binary_probability", d.binary_probability);
  p.joint_probability = r.probability("joint_probability", d.joint_probability);
  p.prior_probability = r.probability("prior_probability", d.prior_probability);
  p.min_observations = r.integer("min_observations", d.min_observations, 2, 1000);
  // Three pairings are the fewest whose joint test has a degree of freedom (2k - 3 > 0).
  p.min_pairings = r.integer("min_pairings", d.min_pairings, 3, 1000);
  p.min_group_pairings = r.integer("min_group_pairings", d.min_group_pairings, 3, p.min_pairings);
  p.min_paired_fraction = r.inRange("min_paired_fraction", d.min_paired_fraction, 0.0, 1.0);
  p.min_seen_fraction = r.inRange("min_seen_fraction", d.min_seen_fraction, 0.0, 1.0);
  p.field_of_view = r.inRange("field_of_view", d.field_of_view, 1e-6, 2.0 * M_PI);
  p.ambiguity_margin = r.integer("ambiguity_margin", d.ambiguity_margin, 0, 1000);
  p.distinct_distance = r.positive("distinct_distance", d.distinct_distance);
  p.distinct_angle = r.inRange("distinct_angle", d.distinct_angle, 1e-6, M_PI);
  p.max_hypotheses = r.integer("max_hypotheses", d.max_hypotheses, 1, 1000000);
  p.max_nodes = r.integer("max_nodes", d.max_nodes, 1, INT_MAX);
  if (p.group_size != 0 && p.group_size < p.min_group_pairings) {
    r.fail("group_size", "must be 0 (one group) or >= min_group_pairings (" +
                             std::to_string(p.min_group_pairings) + "), got " +
                             std::to_string(p.group_size));
  }
  params_ = p;
  unary_gate_ = chi2Quantile(p.unary_probability, 1);
  binary_gate_ = chi2Quantile(p.binary_probability, 1);
  prior_gate_ = chi2Quantile(p.prior_probability, 2);
  joint_chi2_ = Chi2Table(p.joint_probability, 64);
  // The map table depends on the locality radius and the covariance cap.
  if (!given_map_.empty()) buildMap();
}

void GeometricConstraintBB::setMap(const std::vector<MapLandmark>& map) {
  given_map_ = map;
  buildMap();
}

void GeometricConstraintBB::buildMap() {
  std::vector<MapLandmark> capped = given_map_;
  for (MapLandmark& l : capped)
    l.covariance = capCovariance(l.covariance, params_.landmark_sigma_cap);
  map_.build(capped, localityRange());
}

double GeometricConstraintBB::localityRange() const { return params_.sensor_range; }

std::vector<Observation> GeometricConstraintBB::withOwnNoise(
    const std::vector<Observation>& observations) const {
  if (params_.range_sigma <= 0.0 && params_.bearing_sigma <= 0.0) return observations;
  // Only the range-bearing ones: a Cartesian covariance is in other units.
  std::vector<Observation> out = observations;
  for (Observation& o : out) {
    if (o.kind != MeasurementKind::kRangeBearing) continue;
    if (params_.range_sigma > 0.0) {
      o.R(0, 0) = params_.range_sigma * params_.range_sigma;
      o.R(0, 1) = o.R(1, 0) = 0.0;
    }
    if (params_.bearing_sigma > 0.0) {
      o.R(1, 1) = params_.bearing_sigma * params_.bearing_sigma;
      o.R(0, 1) = o.R(1, 0) = 0.0;
    }
  }
  return out;
}

int GeometricConstraintBB::threshold() const {
  return std::max(params_.min_group_pairings, best_ - params_.ambiguity_margin);
}

bool GeometricConstraintBB::samePose(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  return (a.head<2>() - b.head<2>()).norm() < params_.distinct_distance &&
         std::abs(wrapAngle(a.z() - b.z())) < params_.distinct_angle;
}

void GeometricConstraintBB::gatedCandidates(int point, const Eigen::Vector3d& pose,
                                            const Eigen::Matrix3d& cov, double gate,
                                            std::vector<int>* out) const {
  const ObservedPoint& o = points_[point];
  const Eigen::Matrix2d R = rotation2d(pose.z());
  Eigen::Matrix2d dR;
  dR << -std::sin(pose.z()), -std::cos(pose.z()), std::cos(pose.z()), -std::sin(pose.z());
  Eigen::Matrix<double, 2, 3> J;
  J << Eigen::Matrix2d::Identity(), dR * o.p;
  const Eigen::Vector2d q = R * o.p + pose.head<2>();
  const Eigen::Matrix2d Cq = J * cov * J.transpose() + R * o.cov * R.transpose();
  const double radius = std::sqrt(gate * (Cq.trace() + map_.maxVariance()));
  std::vector<int> near;
  map_.query(q, radius, &near);
  const double unary_var = 2.0 * params_.descriptor_sigma * params_.descriptor_sigma;
  for (const int j : near) {
    const MapLandmark& l = map_.landmarks()[j];
    const Eigen::Matrix2d S = Cq + l.covariance;
    const Eigen::LDLT<Eigen::Matrix2d> ldlt(S);
    const Eigen::Vector2d v = l.position - q;
    if (ldlt.info() != Eigen::Success || !(v.dot(ldlt.solve(v)) <= gate)) continue;
    if (!unaryCompatible(o.descriptor, l.descriptor, unary_var, unary_gate_)) continue;
    out->push_back(j);
  }
}

void GeometricConstraintBB::candidatesFor(const PosePrior* prior) {
  const std::size_t n = map_.size();
  const double unary_var = 2.0 * params_.descriptor_sigma * params_.descriptor_sigma;
  candidates_.assign(points_.size(), {});
  allowed_.assign(points_.size(), std::vector<char>(n, 0));
  for (std::size_t i = 0; i < points_.size(); ++i) {
    std::vector<int>& c = candidates_[i];
    if (prior) {
      gatedCandidates(static_cast<int>(i), prior->mean, prior->covariance, prior_gate_, &c);
    } else {
      for (std::size_t j = 0; j < n; ++j) {
        if (unaryCompatible(points_[i].descriptor, map_.landmarks()[j].descriptor, unary_var,
                            unary_gate_))
          c.push_back(static_cast<int>(j));
      }
    }
    for (const int j : c) allowed_[i][j] = 1;
  }
}

void GeometricConstraintBB::makeGroups() {
  const int n = static_cast<int>(points_.size());
  last_groups_.clear();
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  // Nearest to the sensor first: the best measured points seed the groups.
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return points_[a].range < points_[b].range; });
  const int N = params_.group_size;
  if (N == 0 || n <= N) {
    last_groups_.push_back(order);
    return;
  }
  // Compact groups: a seed and its nearest unassigned points (with locality only those closer
  // than the C_ij radius, since farther pairs cannot both be paired). Overlapping: every point
  // seeds a group of its nearest points, assigned or not; a set met before is not searched again.
  const bool overlap = params_.overlapping_groups;
  std::vector<char> assigned(n, 0);
  std::vector<int> covered(n, 0);  // groups each point is in
  const int coverage = overlap ? params_.group_coverage : 0;
  std::vector<std::vector<int>> seen_sets;
  for (const int seed : order) {
    if (assigned[seed] && !overlap) continue;
    if (coverage > 0 && covered[seed] >= coverage) continue;
    std::vector<int> rest;
    for (const int i : order) {
      if ((overlap || !assigned[i]) && i != seed) rest.push_back(i);
    }
    const Eigen::Vector2d s = points_[seed].p;
    std::sort(rest.begin(), rest.end(), [&](int a, int b) {
      return (points_[a].p - s).squaredNorm() < (points_[b].p - s).squaredNorm();
    });
    std::vector<int> group{seed};
    assigned[seed] = 1;
    for (const int i : rest) {
      if (static_cast<int>(group.size()) >= N) break;
      if (params_.use_locality && (points_[i].p - s).norm() >= localityRange()) break;
      group.push_back(i);
      assigned[i] = 1;
    }
    if (overlap) {
      std::vector<int> set = group;
      std::sort(set.begin(), set.end());
      if (std::find(seen_sets.begin(), seen_sets.end(), set) != seen_sets.end()) continue;
      seen_sets.push_back(std::move(set));
    }
    for (const int i : group) ++covered[i];
    last_groups_.push_back(group);
  }
}

bool GeometricConstraintBB::compatible(int point, int landmark) const {
  const ObservedPoint& a = points_[point];
  const MapLandmark& la = map_.landmarks()[landmark];
  for (const int level : paired_levels_) {
    const int j = current_[level];
    if (params_.use_locality && !map_.local(j, landmark)) return false;
    const ObservedPoint& b = points_[(*group_)[level]];
    const MapLandmark& lb = map_.landmarks()[j];
    if (binaryStatistic(a.p, a.cov, b.p, b.cov, la.position, la.covariance, lb.position,
                        lb.covariance) > binary_gate_)
      return false;
  }
  return true;
}

void GeometricConstraintBB::record() {
  if (paired_ < threshold()) return;
  const int k = static_cast<int>(group_->size());
  // Depth first with "paired" branches before "unpaired" ones: a superset is always met before
  // its subsets, so a subset of a kept hypothesis is dropped here.
  for (const Hypothesis& h : kept_) {
    bool subset = true;
    for (int l = 0; l < k && subset; ++l)
      subset = current_[l] == -1 || current_[l] == h.landmark[l];
    if (subset) return;
  }
  if (paired_ > best_) {
    best_ = paired_;
    const int t = threshold();
    kept_.erase(
        std::remove_if(kept_.begin(), kept_.end(), [t](const Hypothesis& h) { return h.size < t; }),
        kept_.end());
  }
  kept_.push_back(Hypothesis{current_, paired_});
  if (static_cast<int>(kept_.size()) > params_.max_hypotheses) too_many_ = true;
}

void GeometricConstraintBB::search(int level) {
  if (budget_exhausted_ || too_many_) return;
  if (++nodes_ > static_cast<std::uint64_t>(params_.max_nodes)) {
    budget_exhausted_ = true;
    return;
  }
  const int k = static_cast<int>(group_->size());
  if (level == k) {
    record();
    return;
  }
  const int remaining = k - level;
  if (paired_ + remaining < threshold()) return;  // the bound
  const int point = (*group_)[level];
  // With locality every later pairing is a neighbour of the first one (C_ij = 1): candidates come
  // from its precomputed list, not from the whole map.
  const bool local = params_.use_locality && !paired_levels_.empty();
  const std::vector<int>& cand =
      local ? map_.neighbours(current_[paired_levels_.front()]) : candidates_[point];
  for (const int l : cand) {
    if (used_[l] || !allowed_[point][l] || !compatible(point, l)) continue;
    current_[level] = l;
    used_[l] = 1;
    paired_levels_.push_back(level);
    ++paired_;
    search(level + 1);
    --paired_;
    paired_levels_.pop_back();
    used_[l] = 0;
    current_[level] = -1;
    if (budget_exhausted_ || too_many_) return;
  }
  if (paired_ + remaining - 1 >= threshold()) search(level + 1);  // unpaired
}

void GeometricConstraintBB::searchGroup(const std::vector<int>& group) {
  group_ = &group;
  current_.assign(group.size(), -1);
  paired_levels_.clear();
  used_.assign(map_.size(), 0);
  paired_ = 0;
  best_ = 0;
  kept_.clear();
  search(0);
}

PoseFit GeometricConstraintBB::fit(const std::vector<std::pair<int, int>>& pairs) const {
  std::vector<PointPairing> pp;
  pp.reserve(pairs.size());
  for (const auto& [point, j] : pairs) pp.push_back({&points_[point], &map_.landmarks()[j]});
  return fitPose(pp);
}

bool GeometricConstraintBB::jointlyCompatible(const PoseFit& f, std::size_t k) const {
  return f.ok && k >= 2 && f.d2 <= joint_chi2_(static_cast<int>(2 * k - 3));
}

GeometricConstraintBB::Verified GeometricConstraintBB::verify(
    const std::vector<std::pair<int, int>>& seeds) const {
  // The seed pairings (a landmark once), refined and tested jointly.
  Verified v;
  std::vector<char> used(map_.size(), 0), point_paired(points_.size(), 0);
  for (const auto& [point, j] : seeds) {
    if (used[j] || point_paired[point]) continue;
    used[j] = point_paired[point] = 1;
    v.pairs.emplace_back(point, j);
  }
  v.fit = fit(v.pairs);
  if (!jointlyCompatible(v.fit, v.pairs.size())) {
    v.pairs.clear();
    return v;
  }
  // Every other observation: paired when exactly one free landmark is compatible with it at this
  // pose, kept if the whole set stays jointly compatible.
  std::vector<std::pair<int, int>> extended = v.pairs;
  std::vector<int> c;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (point_paired[i]) continue;
    c.clear();
    gatedCandidates(static_cast<int>(i), v.fit.pose, v.fit.covariance, prior_gate_, &c);
    c.erase(std::remove_if(c.begin(), c.end(), [&](int j) { return used[j] != 0; }), c.end());
    if (c.size() == 1) {
      used[c[0]] = 1;
      extended.emplace_back(static_cast<int>(i), c[0]);
    }
  }
  if (extended.size() > v.pairs.size()) {
    const PoseFit f = fit(extended);
    if (jointlyCompatible(f, extended.size())) {
      v.fit = f;
      v.pairs = std::move(extended);
    }
  }
  // Negative information: the map landmarks the sensor should see from this pose (from any scan's
  // pose of a window, each counted once).
  std::vector<int> near, in_view;
  for (const Eigen::Vector3d& view : views_) {
    const Eigen::Vector3d sensor = composePose(composePose(v.fit.pose, view), sensor_offset_);
    near.clear();
    map_.query(sensor.head<2>(), view_range_, &near);
    for (const int j : near) {
      const Eigen::Vector2d d = map_.landmarks()[j].position - sensor.head<2>();
      if (std::abs(wrapAngle(std::atan2(d.y(), d.x()) - sensor.z())) <= 0.5 * params_.field_of_view)
        in_view.push_back(j);
    }
  }
  std::sort(in_view.begin(), in_view.end());
  v.expected = static_cast<int>(std::unique(in_view.begin(), in_view.end()) - in_view.begin());
  return v;
}

bool GeometricConstraintBB::begin(const Eigen::Vector3d& sensor_offset, const PosePrior* prior,
                                  RelocalisationResult* result) {
  nodes_ = 0;
  budget_exhausted_ = too_many_ = false;
  last_groups_.clear();
  points_.clear();
  views_.clear();
  if (!sensor_offset.allFinite()) {
    *result = notFound(*result, "sensor offset is not finite");
  } else if (prior && !(prior->mean.allFinite() && prior->covariance.allFinite())) {
    *result = notFound(*result, "pose prior is not finite");
  } else if (map_.size() < 3) {
    *result = notFound(*result, "the map has " + std::to_string(map_.size()) +
                                    " usable landmarks (at least 3 needed)");
  } else {
    sensor_offset_ = sensor_offset;
    return true;
  }
  return false;
}

double GeometricConstraintBB::maxRange() const {
  return params_.max_observation_range > 0.0 ? params_.max_observation_range
                                             : std::numeric_limits<double>::infinity();
}

RelocalisationResult GeometricConstraintBB::relocalise(const std::vector<Observation>& observations,
                                                       const Eigen::Vector3d& sensor_offset,
                                                       const PosePrior* prior) {
  RelocalisationResult result;
  result.landmark.assign(observations.size(), kNoLandmark);
  if (!begin(sensor_offset, prior, &result)) return result;
  points_ = observedPoints(withOwnNoise(observations), sensor_offset, maxRange());
  views_.push_back(Eigen::Vector3d::Zero());
  return solve(prior, std::move(result));
}

RelocalisationResult GeometricConstraintBB::relocaliseWindow(const std::vector<CarriedScan>& scans,
                                                             const Eigen::Vector3d& sensor_offset,
                                                             const PosePrior* prior) {
  RelocalisationResult result;
  std::vector<int> first(scans.size(), 0);  // index of each scan's first observation
  int n = 0;
  for (std::size_t s = 0; s < scans.size(); ++s) {
    first[s] = n;
    n += static_cast<int>(scans[s].observations.size());
  }
  result.landmark.assign(static_cast<std::size_t>(n), kNoLandmark);
  if (!begin(sensor_offset, prior, &result)) return result;
  // Newest first: a tree seen again by a newer scan keeps its newest sighting (a tree twice in
  // the point set could be paired only once, and would lower the paired share).
  for (std::size_t s = scans.size(); s-- > 0;) {
    const CarriedScan& c = scans[s];
    if (!c.origin.allFinite() || !c.origin_covariance.allFinite()) continue;
    views_.push_back(c.origin);
    const std::size_t newer = points_.size();
    for (ObservedPoint p :
         observedPoints(withOwnNoise(c.observations), sensor_offset, maxRange())) {
      carryPoint(c.origin, c.origin_covariance, &p.p, &p.cov);
      p.input += first[s];
      bool again = false;
      for (std::size_t k = 0; k < newer && !again; ++k) {
        const Eigen::Vector2d d = p.p - points_[k].p;
        again = d.dot((p.cov + points_[k].cov).ldlt().solve(d)) <= prior_gate_;
      }
      if (!again) points_.push_back(p);
    }
  }
  return solve(prior, std::move(result));
}

RelocalisationResult GeometricConstraintBB::solve(const PosePrior* prior,
                                                  RelocalisationResult result) {
  if (static_cast<int>(points_.size()) < params_.min_observations) {
    return notFound(result, std::to_string(points_.size()) + " usable observations (at least " +
                                std::to_string(params_.min_observations) + " needed)");
  }
  // "In view" for the negative information: as far as the sensor is trusted, else as far as it
  // saw this time.
  view_range_ = params_.max_observation_range;
  if (view_range_ <= 0.0) {
    for (const ObservedPoint& p : points_) view_range_ = std::max(view_range_, p.range);
  }
  candidatesFor(prior);
  makeGroups();

  // 3-4. Search each group; score its kept hypotheses. A group with more than max_hypotheses
  // near-equal hypotheses says nothing: it proposes no pose (the others still may).
  std::vector<Scored> scored;
  int uninformative = 0;
  for (std::size_t g = 0; g < last_groups_.size(); ++g) {
    const std::vector<int>& group = last_groups_[g];
    if (static_cast<int>(group.size()) < params_.min_group_pairings) continue;  // left to step 5
    too_many_ = false;
    searchGroup(group);
    if (budget_exhausted_) break;
    if (too_many_) {
      ++uninformative;
      continue;
    }
    for (const Hypothesis& h : kept_) {
      Scored s;
      s.group = static_cast<int>(g);
      for (std::size_t l = 0; l < group.size(); ++l) {
        if (h.landmark[l] >= 0) s.pairs.emplace_back(group[l], h.landmark[l]);
      }
      s.fit = fit(s.pairs);
      if (jointlyCompatible(s.fit, s.pairs.size())) scored.push_back(std::move(s));
    }
  }
  result.nodes = nodes_;
  // Groups back to observation indices, for lastGroups().
  for (auto& group : last_groups_) {
    for (int& i : group) i = points_[i].input;
  }
  if (budget_exhausted_) {
    return notFound(result,
                    "search budget of " + std::to_string(params_.max_nodes) +
                        " nodes spent: other hypotheses cannot be ruled out",
                    RelocalisationStatus::kAmbiguous);
  }
  if (scored.empty() && uninformative > 0) {
    return notFound(result,
                    "more than " + std::to_string(params_.max_hypotheses) +
                        " hypotheses explain each group of observations about equally well",
                    RelocalisationStatus::kAmbiguous);
  }

  // 5. Pose clusters: proposals (best first) whose poses agree are one candidate pose; each is
  // verified against every observation and scored by how many it explains.
  std::sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) {
    return a.pairs.size() != b.pairs.size() ? a.pairs.size() > b.pairs.size() : a.fit.d2 < b.fit.d2;
  });
  struct Cluster {
    Eigen::Vector3d pose;
    std::vector<int> best;  // per group: index into scored or -1
    Verified verified;
  };
  std::vector<Cluster> clusters;
  // Clusters by position cell (distinct_distance): a proposal is compared with the clusters of
  // its cell and the eight around it, not with every cluster.
  std::unordered_map<std::int64_t, std::vector<int>> cells;
  const auto cellOf = [&](const Eigen::Vector3d& pose, int dx, int dy) {
    const auto ix = static_cast<std::int64_t>(std::floor(pose.x() / params_.distinct_distance));
    const auto iy = static_cast<std::int64_t>(std::floor(pose.y() / params_.distinct_distance));
    return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix + dx) << 32) ^
                                     (static_cast<std::uint64_t>(iy + dy) & 0xffffffffULL));
  };
  for (std::size_t s = 0; s < scored.size(); ++s) {
    const Eigen::Vector3d& pose = scored[s].fit.pose;
    int found = -1;
    for (int dx = -1; dx <= 1 && found < 0; ++dx) {
      for (int dy = -1; dy <= 1 && found < 0; ++dy) {
        const auto it = cells.find(cellOf(pose, dx, dy));
        if (it == cells.end()) continue;
        for (const int c : it->second) {
          if (samePose(clusters[c].pose, pose)) {
            found = c;
            break;
          }
        }
      }
    }
    if (found < 0) {
      found = static_cast<int>(clusters.size());
      clusters.push_back(Cluster{pose, std::vector<int>(last_groups_.size(), -1), {}});
      cells[cellOf(pose, 0, 0)].push_back(found);
    }
    int& b = clusters[found].best[scored[s].group];
    if (b < 0) b = static_cast<int>(s);
  }
  for (Cluster& c : clusters) {
    std::vector<std::pair<int, int>> seeds;
    for (const int s : c.best) {
      if (s >= 0) seeds.insert(seeds.end(), scored[s].pairs.begin(), scored[s].pairs.end());
    }
    c.verified = verify(seeds);
  }
  std::stable_sort(clusters.begin(), clusters.end(), [](const Cluster& a, const Cluster& b) {
    return a.verified.pairs.size() > b.verified.pairs.size();
  });
  const int usable = static_cast<int>(points_.size());
  const int needed = std::max(params_.min_pairings,
                              static_cast<int>(std::ceil(params_.min_paired_fraction * usable)));
  if (clusters.empty() || static_cast<int>(clusters[0].verified.pairs.size()) < needed) {
    std::ostringstream why;
    why << "no pose explains " << needed << " of the " << usable << " usable observations";
    if (!clusters.empty())
      why << " (the best explains " << clusters[0].verified.pairs.size() << ")";
    return notFound(result, why.str());
  }
  const int best_score = static_cast<int>(clusters[0].verified.pairs.size());
  if (best_score < params_.min_seen_fraction * clusters[0].verified.expected) {
    std::ostringstream why;
    why << "the best pose explains " << best_score << " observations but "
        << clusters[0].verified.expected << " map landmarks should be in view there";
    return notFound(result, why.str());
  }
  if (clusters.size() > 1 && static_cast<int>(clusters[1].verified.pairs.size()) >=
                                 best_score - params_.ambiguity_margin) {
    std::ostringstream why;
    why << "the runner-up pose explains " << clusters[1].verified.pairs.size()
        << " observations, the best " << best_score;
    return notFound(result, why.str(), RelocalisationStatus::kAmbiguous);
  }
  const PoseFit& best = clusters[0].verified.fit;
  const std::vector<std::pair<int, int>>& pairs = clusters[0].verified.pairs;

  result.status = RelocalisationStatus::kFound;
  result.pose = best.pose;
  result.covariance = best.covariance;
  result.joint_mahalanobis = best.d2;
  result.hypothesis_size = static_cast<int>(pairs.size());
  for (const auto& [point, j] : pairs)
    result.landmark[points_[point].input] = map_.landmarks()[j].id;
  return result;
}

}  // namespace ekf_slam
