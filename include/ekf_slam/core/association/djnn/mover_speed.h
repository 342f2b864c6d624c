// DJNN extension "movers' speed learned online" (learn_mover_speed; docs/djnn.md, "Movers' speed
// learned from the landmarks they left"): a landmark DJNN admitted that is removed again with
// fewer than admit_evidence pairings, and with no other landmark at its place, was a mover that
// got in. The static test then waits, at every admission, until the sightings resolve half the
// median speed those movers resolved (StaticTest::minSpeed). mover_wait_budget bounds that wait
// by what the map's own landmarks afford: each admitted landmark's sightings within
// tentative_timeout of its first one resolve a speed, and the learned speed is kept at least at
// the one all but the budget's share of them resolved. A sample from a static landmark lost by
// chance, or from a robot that stood still, can otherwise ask for a wait no landmark outlives.
// mover_left_odds: a removed landmark is a mover that left only once its place has been looked at
// and found empty often enough that a static point still there would have shown itself; a return
// at the place starts the count again, a landmark admitted there ends the watch.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/association/djnn/static_test.h"
#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class MoverSpeed {
 public:
  struct Params {
    bool learn_mover_speed = false;
    int mover_speed_samples = 1;  ///< movers seen before the estimate is used
    /// The share of admitted landmarks the learned wait may keep out of the map past
    /// tentative_timeout; 0: no bound.
    double mover_wait_budget = 0.2;
    /// The odds (left : still there) the empty looks at a removed landmark's place must reach
    /// before it counts as a mover that left; 0: it counts when removed.
    double mover_left_odds = 100.0;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  bool on() const { return p_.learn_mover_speed; }
  /// The window a landmark's sightings are counted in: the tentative feature's lifetime.
  void configure(double tentative_timeout);
  /// Forgets everything learned (a new run).
  void reset();

  /// A scan of m observations begins.
  void beginScan(int m);
  /// Observation obs admits feature t (its track and the speed `test` says it resolved).
  void admitting(int obs, const Tentative& t, const StaticTest& test);
  /// ... as landmark id.
  void landmarkAdded(int obs, LandmarkId id);
  /// After the scan's decisions: the admitted landmarks' pairings, misses and windows, the
  /// places of the landmarks removed unestablished (with no landmark of the scan's candidates
  /// within the tentative gate of them), and the movers that left.
  void scanDone(const AssociationContext& ctx, const AssociationResult& result,
                const DjnnPaper& paper, const LocalScan& scan, int admit_evidence,
                const StaticTest& test);

  /// The events scanDone finds: a mover that left, admitted at resolved speed `speed`; the
  /// window of an admitted landmark ended, its sightings having resolved `speed`.
  void moverLeft(double speed);
  void windowEnded(double speed);

  /// The speed the static test waits for: the learned one, at least the bound; 0 before
  /// mover_speed_samples movers left.
  double speed() const;
  /// Half the median resolved speed of the movers that left (0 before enough of them).
  double learned() const { return learned_; }
  /// The wait's bound: the speed all but mover_wait_budget of the admitted landmarks resolved
  /// within their window (0 before 1 / mover_wait_budget windows ended).
  double bound() const { return bound_; }
  /// The resolved speeds of the movers that left so far [m/s], in order.
  const std::vector<double>& moverSpeeds() const { return mover_speeds_; }
  /// The speeds the admitted landmarks' windows resolved so far [m/s], in order.
  const std::vector<double>& windowSpeeds() const { return window_speeds_; }
  /// Removed landmarks whose place is watched (mover_left_odds), and those whose place showed a
  /// landmark again (a static point the map lost: no sample).
  std::size_t watchedPlaces() const { return leavers_.size(); }
  std::size_t placesStillOccupied() const { return still_there_; }

 private:
  /// A landmark DJNN admitted: the speed its sightings resolved then, its pairings since, and
  /// the track of its sightings within the window (position, velocity information).
  struct Admitted {
    double resolved_speed = 0.0;
    int pairings = 0;
    Eigen::Matrix4d track_info = Eigen::Matrix4d::Zero();
    double first_seen = 0.0;
    bool in_window = true;
    std::uint64_t last_paired = 0;  ///< the scan it was last paired in
    int misses = 0;                 ///< looks at it since, none paired
  };
  /// The place of a landmark removed unestablished, watched until it shows empty or occupied.
  struct Leaver {
    /// At the removal, in the map frame (later corrections do not move it: the watch is short).
    Eigen::Vector2d position;
    Eigen::Matrix2d covariance;
    double speed = 0.0;       ///< the speed its sightings resolved at admission
    double removed_at = 0.0;  ///< [s]
    double log_odds = 0.0;  ///< ln P(looks | left) / P(looks | still there), since the last return
  };
  void countMisses(const AssociationContext& ctx, const DjnnPaper& paper, const LocalScan& scan,
                   int admit_evidence);
  /// The watched places seen by this scan: counts them and learns from the ones that left.
  void watchPlaces(const AssociationContext& ctx, const AssociationResult& result,
                   const DjnnPaper& paper, const LocalScan& scan);
  /// Counts a place as left (moverLeft) once its odds reach mover_left_odds; returns whether.
  bool leftIfSure(const Leaver& l);
  Params p_;
  double window_ = 0.0;            ///< tentative_timeout [s]; 0: no bound
  std::vector<Admitted> pending_;  ///< per observation of the scan; resolved_speed < 0: none
  std::unordered_map<LandmarkId, Admitted> admitted_;
  std::vector<LandmarkId> in_window_;  ///< admitted landmarks whose window is open
  std::vector<Leaver> leavers_;
  std::size_t still_there_ = 0;
  std::uint64_t scans_ = 0;
  std::vector<double> mover_speeds_;
  std::vector<double> window_speeds_;
  double learned_ = 0.0;
  double bound_ = 0.0;
};

}  // namespace ekf_slam
