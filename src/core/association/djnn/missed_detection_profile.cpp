#include "ekf_slam/core/association/djnn/missed_detection_profile.h"

namespace ekf_slam {

const std::map<std::string, std::string>& missedDetectionDefaults() {
  // Each measured on `fiducials` / `arena` (docs/djnn.md, "A sensor that misses landmarks").
  static const std::map<std::string, std::string> defaults = {
      {"tentative_follow_pose", "true"},               // FollowPose
      {"static_heading", "true"},                      // StaticTest
      {"waive_velocity_test_without_movers", "true"},  // StaticTest
      {"chance_failures_without_movers", "true"},      // StaticTest
      {"sightings_admit_without_movers", "true"},      // StaticTest
      {"learn_mover_speed", "true"},                   // MoverSpeed: the movers' speed, online
      {"density_test", "true"},       // DensityTest (its density: estimated by default)
      {"bias_keep_pairings", "10"},   // BiasTest: established landmarks
      {"remembered_sightings", "2"},  // RememberedFeatures
      {"held_birth_cost", "4"},       // RememberedFeatures: a feature born held
      {"held_confirmations", "1"},    // HeldConfirmation
  };
  return defaults;
}

}  // namespace ekf_slam
