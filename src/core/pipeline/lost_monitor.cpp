#include "ekf_slam/core/pipeline/lost_monitor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

LostMonitor::LostMonitor(const PipelineConfig& config, const EkfSlam& filter,
                         const LandmarkIndex& index, const RangeBearingModel& model,
                         const LandmarkBook& book)
    : config_(config),
      filter_(filter),
      index_(index),
      model_(model),
      book_(book),
      nis_chi2_(config.lost_nis_probability, 64),
      seen_rate_(2.0 * config.lost_min_paired_share),
      explained_rate_(2.0 * config.lost_min_paired_share) {
  // Only the polygon is tested through it: landmarksInView checks the range and the wedge.
  view_.max_range = std::numeric_limits<double>::infinity();
  view_.field_of_view = 2.0 * M_PI;
  view_.polygon = config.lost_view_polygon;
}

void LostMonitor::restart() {
  unpaired_streak_ = nis_streak_ = refused_streak_ = 0;
  share_window_.clear();
}

void LostMonitor::reset() {
  restart();
  // Until learned: what the sensor pairs when it sees all in view, twice the share set.
  seen_rate_ = explained_rate_ = 2.0 * config_.lost_min_paired_share;
  seen_samples_ = explained_samples_ = 1;
}

double LostMonitor::learnedShare(double rate) const {
  const double share = config_.lost_min_paired_share;
  return config_.lost_share_learning_scans > 0 ? std::min(share, 0.5 * rate) : share;
}

int LostMonitor::landmarksInView(std::uint32_t scans) const {
  const Eigen::Vector3d sensor = model_.sensorPose(filter_.pose());
  const double range =
      config_.lost_view_range > 0.0 ? config_.lost_view_range : config_.max_observation_range;
  std::vector<int> near;
  index_.query(filter_, sensor.head<2>(), range, &near);
  int expected = 0;
  for (const int k : near) {
    // Recent landmarks say nothing about being lost.
    if (book_.recent(filter_.landmarkIds()[k], scans)) continue;
    const Eigen::Vector2d d = filter_.landmark(k) - sensor.head<2>();
    if (!(std::abs(wrapAngle(std::atan2(d.y(), d.x()) - sensor.z())) <=
          0.5 * config_.lost_field_of_view))
      continue;
    // The sensor's footprint, in the sensor frame.
    if (view_.polygon.size() >= 3 && !view_.contains(Eigen::Rotation2Dd(-sensor.z()) * d, 0.0, 0.0))
      continue;
    ++expected;
  }
  return expected;
}

LostMonitor::Verdict LostMonitor::afterUpdate(ScanReport* report) {
  const AssociationResult& a = report->association;
  const int n = static_cast<int>(report->observations.size());
  const std::uint32_t scans = report->scan + 1;
  // Rule 1: observations, none paired with an established landmark, for several scans. Pairings
  // with recent landmarks do not count: a kidnapped filter maps the place it is in anew, and
  // pairs with what it has just mapped.
  int established = 0, recent = 0;
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    if (a.decision[i] != Decision::kPaired) continue;
    (book_.recent(a.landmark[i], scans) ? recent : established) += 1;
  }
  // lost_min_paired_share > 0: a few chance pairings among many landmarks in view still count
  // as unpaired.
  const bool share_rule = config_.lost_min_paired_share > 0.0;
  if (share_rule) report->landmarks_expected = landmarksInView(scans);
  // Nor is a scan unpaired whose observations the established map explains: of those not
  // explained by recent landmarks (new ground being mapped), at least the share. Landmarks in view
  // that are never seen again (movers an associator mapped) then do not make a tracking filter
  // lost. With a share of 0 the first test always holds. The shares as learned (at most the one
  // set): what these scans have paired, not what the sensor's datasheet promises.
  const double seen_share = learnedShare(seen_rate_);
  const double explained_share = learnedShare(explained_rate_);
  if (established > 0 && (established >= seen_share * report->landmarks_expected ||
                          established >= explained_share * (n - recent))) {
    unpaired_streak_ = 0;
  } else if (n >= config_.lost_min_observations &&
             (!share_rule ||
              report->landmarks_expected - established >= config_.lost_min_expected)) {
    // (With the share rule a scan counts only when it missed lost_min_expected established
    // landmarks in view: two or three cannot tell a kidnap from misses, an associator holding
    // back, or new ground.)
    ++unpaired_streak_;
  }
  if (share_rule && config_.lost_share_learning_scans > 0) {
    // Learned after the scan is judged, so that it does not excuse itself.
    // A mean of the scans so far (the prior counts as one), then an exponential one over about
    // lost_share_learning_scans: a sensor that pairs little from the start is learned within
    // a few scans, not only after many of them were judged against the prior.
    const auto learn = [this](double x, double* rate, int* samples) {
      *samples = std::min(*samples + 1, config_.lost_share_learning_scans);
      *rate += (x - *rate) / std::max(*samples, 1);
    };
    if (report->landmarks_expected >= std::max(config_.lost_min_expected, 1))
      learn(static_cast<double>(established) / report->landmarks_expected, &seen_rate_,
            &seen_samples_);
    if (n - recent >= std::max(config_.lost_min_observations, 1))
      learn(static_cast<double>(established) / (n - recent), &explained_rate_, &explained_samples_);
  }
  // Rule 2: the paired observations persistently disagree with the filter.
  const int paired =
      static_cast<int>(std::count(a.decision.begin(), a.decision.end(), Decision::kPaired));
  if (paired > 0 && report->update_ok) {
    nis_streak_ = report->nis > nis_chi2_(report->nis_dof) ? nis_streak_ + 1 : 0;
  }
  const bool unpaired =
      config_.lost_unpaired_scans > 0 && unpaired_streak_ >= config_.lost_unpaired_scans;
  if (unpaired && !share_rule) report->landmarks_expected = landmarksInView(scans);
  const bool rule1 = unpaired && report->landmarks_expected >= config_.lost_min_expected;
  const bool rule2 = config_.lost_nis_scans > 0 && nis_streak_ >= config_.lost_nis_scans;
  // Rule 4: over the last lost_share_window scans with established landmarks in view, too few
  // observations explained by them. Chance pairings (one or two a scan among many landmarks in
  // view) restart rule 1's count but hardly raise this share (docs/relocalisation.md).
  bool rule4 = false;
  if (config_.lost_share_window > 0 && n >= config_.lost_min_observations) {
    if (!share_rule && !unpaired) report->landmarks_expected = landmarksInView(scans);
    if (report->landmarks_expected >= config_.lost_min_expected) {
      share_window_.emplace_back(established, n);
      if (share_window_.size() > static_cast<std::size_t>(config_.lost_share_window))
        share_window_.pop_front();
      int window_established = 0, window_observations = 0;
      for (const auto& [e, o] : share_window_) {
        window_established += e;
        window_observations += o;
      }
      rule4 = share_window_.size() == static_cast<std::size_t>(config_.lost_share_window) &&
              window_established < config_.lost_established_share * window_observations;
      if (rule4) {
        report->lost_reason = std::to_string(window_established) + " of " +
                              std::to_string(window_observations) +
                              " observations paired with established landmarks in " +
                              std::to_string(config_.lost_share_window) + " scans";
      }
    }
  }
  // Rule 4's probe: a scan with established landmarks in view of which it explains under
  // lost_established_share by them (rule 4's share, one scan), with too few scans or too few in
  // view for a rule to call it lost. A kidnap shows at once as such a scan (Victoria Park: one
  // chance pairing of 8-10 observations), yet so does a tracking filter among trees the laser
  // misses, so the relocaliser decides, as for rule 1 with few in view.
  bool share_probe = false;
  if (config_.lost_share_probe && !rule1 && !rule2 && !rule4 &&
      n >= std::max(config_.lost_min_observations, 1) &&
      established < config_.lost_established_share * n) {
    if (config_.lost_share_window <= 0) report->landmarks_expected = landmarksInView(scans);
    share_probe = report->landmarks_expected > 0;
  }
  if (rule1 || rule4) {
    if (rule1) {
      report->lost_reason = (share_rule ? "under " + std::to_string(learnedShare(seen_rate_)) +
                                              " of the established landmarks in view paired for "
                                        : std::string("no established landmark paired for ")) +
                            std::to_string(unpaired_streak_) + " scans, " +
                            std::to_string(report->landmarks_expected) + " in view";
    }
    return Verdict::kLost;
  }
  // Rule 2 asks the relocaliser: the pairings disagree with the filter, which a loop closed after
  // a long drift or an inconsistent filter (biased odometry) shows as well as a kidnap; lost only
  // when the relocaliser puts the vehicle where the estimate does not cover.
  if (rule2) {
    report->lost_reason = "NIS above chi2(2k, " + std::to_string(config_.lost_nis_probability) +
                          ") for " + std::to_string(nis_streak_) + " scans";
    return Verdict::kProbe;
  }
  // Nothing established paired and nothing established in view: new ground, or a kidnap into a
  // place the filter takes for new ground. The relocaliser tells them apart: a confident pose in
  // the established map that the filter's estimate does not cover is a kidnap.
  return unpaired || share_probe ? Verdict::kProbe : Verdict::kTracking;
}

bool LostMonitor::suspect(const ScanReport& report, int* established) const {
  const AssociationResult& a = report.association;
  const int n = static_cast<int>(report.observations.size());
  const std::uint32_t scans = report.scan + 1;
  int recent = 0;
  *established = 0;
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    if (a.decision[i] != Decision::kPaired) continue;
    (book_.recent(a.landmark[i], scans) ? recent : *established) += 1;
  }
  if (n < std::max(config_.lost_min_observations, 1)) return false;
  // What rule 4 counts on one scan, or what rule 1 counts as unpaired.
  const bool low = *established == 0 || *established < config_.lost_established_share * n ||
                   *established < config_.lost_min_paired_share * (n - recent);
  return low && landmarksInView(scans) > 0;
}

LostMonitor::Refusal LostMonitor::refused(const ScanReport& report, std::string* reason) {
  if (config_.lost_rejected_scans <= 0) return Refusal::kNone;
  const AssociationResult& a = report.association;
  const int paired =
      static_cast<int>(std::count(a.decision.begin(), a.decision.end(), Decision::kPaired));
  // Rule 3: the associator recognised these landmarks without the pose, and the filter refused
  // them, more than it paired. Seen at the first scan after a kidnap, while rule 1 waits for
  // several scans (and chance pairings restart it).
  if (a.gate_refused < std::max(config_.lost_min_observations, 1) || a.gate_refused <= paired) {
    refused_streak_ = 0;
    return Refusal::kNone;
  }
  // Its unrecognised observations would start landmarks at the wrong pose: a second copy of the
  // map that the filter would then track.
  if (++refused_streak_ < config_.lost_rejected_scans) return Refusal::kSuppress;
  *reason = std::to_string(a.gate_refused) +
            " observations recognised but refused by the filter gate (" + std::to_string(paired) +
            " paired) for " + std::to_string(refused_streak_) + " scans";
  return Refusal::kProbe;
}

void LostMonitor::suppressNew(AssociationResult* association, PipelineCounters* counters) {
  for (Decision& d : association->decision) {
    if (d != Decision::kNew) continue;
    d = Decision::kRejected;
    ++counters->suppressed_new;
  }
}

}  // namespace ekf_slam
