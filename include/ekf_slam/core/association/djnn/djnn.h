// Dynamic Joint Nearest Neighbour, DJNN: the default associator. The paper's algorithm (seed 000
// section 3; djnn_paper.h: local region, interference cases 1-4, evidence counter) plus the
// package's extensions, each a named part with its own parameters, switched on by configuration:
//
//   part                 parameters                      failure it fixes (docs/djnn.md)
//   EvidenceModel        detection_probability, clutter_density
//                                                        sensors that miss landmarks or see clutter
//   AmbiguityGate        ambiguity_probability           duplicates of a landmark left unpaired
//                        tentative_ambiguity             a tentative feature split in two by one
//                                                        sighting just outside its gate
//   StaticTest           static_*                        slow movers admitted as landmarks
//   MoverSpeed           learn_mover_speed, mover_wait_budget
//                                                        the same, with no speed stated
//                        mover_left_odds                 a static point the map lost taken for
//                                                        a mover that left
//   BiasTest             bias_*                          landmarks dragged along by movers
//   FollowPose           tentative_follow_pose           tentative features left behind when
//                                                        the pose is corrected
//   OptimalAssignment    optimal_assignment              returns of close landmarks left swapped by
//                                                        the greedy resolution of interference
//                        assign_unpaired                 interference losers rejected as ambiguous
//                                                        where a landmark was free for them
//   DensityTest          density_test, landmark_density, estimate_landmark_density
//                                                        a new landmark paired with an old one
//   missed-detection profile (missed_detection_profile.h): the defaults of the parts above for a
//                        sensor with detection_probability < 1
//   DetectionEstimate    detection_probability not set, detection_switch_level
//                                                        a sensor that misses landmarks configured
//                                                        as one that sees them all
//   JointDecision        loop_closure_age, joint_margin  wrong pairings at loop closures (its
//                                                        "not in the map": UnmappedReturns')
//   UnmappedReturns      measure_unmapped_density        closures made or held on a null that
//                                                        overstates what is left unmapped
//   RememberedFeatures   remembered_sightings, held_birth_cost   holes in the map at closures
//   LandmarkSpacing      landmark_spacing                duplicates after an over-confident closure
//   HeldConfirmation     held_confirmations              a closure decided on one scan's noise
//   OccludedMisses       occlusion_aware_misses          landmarks hidden behind nearer returns
//                                                        removed as missed
//   BeamSpacingMisses    beam_spacing_misses             thin poles that fall between the beams
//                                                        removed, or dropped while tentative
//   HeldSightings        held_sightings                  the sightings held at a closure dropped
//                                                        once it is decided
//
// associate() reads as the paper's steps with the parts' calls between them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/djnn/ambiguity_gate.h"
#include "ekf_slam/core/association/djnn/beam_spacing_misses.h"
#include "ekf_slam/core/association/djnn/bias_test.h"
#include "ekf_slam/core/association/djnn/density_test.h"
#include "ekf_slam/core/association/djnn/detection_estimate.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/follow_pose.h"
#include "ekf_slam/core/association/djnn/held_confirmation.h"
#include "ekf_slam/core/association/djnn/held_sightings.h"
#include "ekf_slam/core/association/djnn/joint_decision.h"
#include "ekf_slam/core/association/djnn/landmark_spacing.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/association/djnn/mover_speed.h"
#include "ekf_slam/core/association/djnn/occluded_misses.h"
#include "ekf_slam/core/association/djnn/optimal_assignment.h"
#include "ekf_slam/core/association/djnn/remembered_features.h"
#include "ekf_slam/core/association/djnn/static_test.h"
#include "ekf_slam/core/association/djnn/unmapped_returns.h"

namespace ekf_slam {

class DJNN : public DataAssociation, private FeatureRules {
 public:
  using Case = DjnnCase;
  using Stats = DjnnStats;

  /// Every part's parameters (names as read in configure(); defaults in docs/djnn.md).
  struct Params {
    DjnnPaperParams paper;
    AmbiguityGate::Params ambiguity;
    StaticTest::Params static_test;
    MoverSpeed::Params mover_speed;
    BiasTest::Params bias;
    FollowPose::Params follow_pose;
    DensityTest::Params density;
    JointDecision::Params joint;
    RememberedFeatures::Params remembered;
    LandmarkSpacing::Params spacing;
    HeldConfirmation::Params confirmation;
    OccludedMisses::Params occlusion;
    OptimalAssignment::Params assignment;
    BeamSpacingMisses::Params beam_spacing;
    HeldSightings::Params held_sightings;
    UnmappedReturns::Params unmapped;
    DetectionEstimate::Params detection;
  };

  DJNN();

  void configure(const ParameterSource& params) override;
  std::string name() const override { return "DJNN"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void landmarkAdded(int obs, LandmarkId id) override;
  void landmarkLoaded(LandmarkId id, std::uint32_t times_observed) override;
  bool landmarkOverLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                             const std::vector<LostLook>& looks) override;
  bool landmarkFromLostScans(LandmarkId id, const Eigen::Matrix2d& cov,
                             const std::vector<LostLook>& looks) override;
  void poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) override;
  void reset() override;
  int evidence(LandmarkId id) const override { return paper_.evidence(id); }
  std::vector<TentativeFeature> tentativeFeatures() const override;

  const Params& params() const { return p_; }
  /// The density of unmapped landmarks in use: landmark_density, or its online estimate.
  double landmarkDensity() const { return density_test_.density(); }
  /// P_D of the evidence steps: detection_probability, or its online estimate (DetectionEstimate).
  double detectionProbability() const { return paper_.params().sensor.detection_probability; }
  const DetectionEstimate& detectionEstimate() const { return detection_; }
  /// What learn_mover_speed learned: MoverSpeed::speed() is the speed the static test uses.
  const MoverSpeed& moverSpeed() const { return mover_speed_; }
  Case lastCase() const { return last_case_; }
  const Stats& stats() const { return stats_; }
  /// v_bar (range, bearing) that decided the pairing of the last scan (zero in case 1).
  const Eigen::Vector2d& lastCompensation() const { return scan_.v_bar; }

 private:
  // FeatureRules: the extensions' share of the paper's tentative-feature step.
  Eigen::Matrix2d gateCovariance(const Eigen::Matrix2d& cov_obs, const Matrix23d& G_pose,
                                 const Eigen::Matrix3d& P_vv, double* lever_var) const override;
  double detectable(const AssociationContext& ctx, double range) const override {
    return beam_spacing_.detectable(ctx, range);
  }
  double withholdGate() const override { return ambiguity_.tentativeGate(paper_.tentativeGate()); }
  bool stillStatic(const AssociationContext& ctx, int obs, Tentative* t, const Sighting& s,
                   const Eigen::Matrix2d& C, double stamp) override;
  void started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
               double stamp) override;
  void dropping(const AssociationContext& ctx, int slot, bool stale) override;
  void sighted(const AssociationContext& ctx, int slot, int obs, bool born) override;
  Decision decide(const AssociationContext& ctx, int obs, int slot, double evidence,
                  bool paper_admits) override;
  /// DetectionEstimate found that the sensor misses landmarks: the profile's parameters on.
  void missesDetected(AssociationResult* result);

  Params p_;
  DjnnPaper paper_;  // with its EvidenceModel
  AmbiguityGate ambiguity_;
  StaticTest static_test_;
  MoverSpeed mover_speed_;
  BiasTest bias_test_;
  FollowPose follow_pose_;
  DensityTest density_test_;
  JointDecision joint_;
  RememberedFeatures remembered_;
  LandmarkSpacing spacing_;
  HeldConfirmation confirmation_;
  OccludedMisses occlusion_;
  OptimalAssignment assignment_;
  BeamSpacingMisses beam_spacing_;
  HeldSightings held_sightings_;
  UnmappedReturns unmapped_;
  DetectionEstimate detection_;
  /// The parts' parameters with the missed-detection profile, for DetectionEstimate's switch.
  struct Profiled {
    StaticTest::Params static_test;
    MoverSpeed::Params mover_speed;
    FollowPose::Params follow_pose;
    DensityTest::Params density;
    BiasTest::Params bias;
    RememberedFeatures::Params remembered;
    HeldConfirmation::Params confirmation;
  };
  Profiled profiled_;

  LocalScan scan_;
  std::vector<double> pending_new_;  ///< per observation of the last scan: T at admission, or -1
  Case last_case_ = Case::kNone;
  Stats stats_;
};

}  // namespace ekf_slam
