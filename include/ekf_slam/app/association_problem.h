// One data-association problem (EKF state + one scan), saved as JSON so that a scan can be
// replayed through any associator outside the SLAM run (tools/replay_association, the offline
// runner's dumps, tests). ROS-free. Format: docs/replay_association.md.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

/// A malformed problem file; the message names the file and the field.
class ProblemError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct AssociationProblem {
  Eigen::VectorXd state;       ///< [x, y, yaw, l0x, l0y, l1x, l1y, ...]
  Eigen::MatrixXd covariance;  ///< (3 + 2n) x (3 + 2n)
  Eigen::Vector3d sensor_offset = Eigen::Vector3d::Zero();  ///< x, y, yaw in the vehicle frame
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();          ///< noise of every observation
  std::vector<Eigen::Vector2d> observations;  ///< (range, bearing from the sensor's x axis)
  /// Significance levels alpha (tail probabilities, 0 < alpha <= 0.5) of the individual gate
  /// chi2(2, 1 - alpha) and of the joint gate chi2(2k, 1 - alpha); unset: the associator's own.
  std::optional<double> chi2_alpha_individual;
  std::optional<double> chi2_alpha_joint;
  std::string description;  ///< free text

  std::size_t numLandmarks() const {
    return state.size() >= 3 ? static_cast<std::size_t>(state.size() - 3) / 2 : 0;
  }
  /// Throws ProblemError (prefixed with `origin`) when sizes or values are inconsistent.
  void validate(const std::string& origin = "problem") const;
};

/// Parses and validates; throws ProblemError naming `origin` and the offending field.
AssociationProblem parseAssociationProblem(const std::string& json_text,
                                           const std::string& origin = "<json>");
AssociationProblem readAssociationProblem(const std::string& path);
/// Pretty JSON that parseAssociationProblem reads back exactly (doubles round-trip).
std::string toJson(const AssociationProblem& problem);
/// Throws ProblemError when the file cannot be written.
void writeAssociationProblem(const AssociationProblem& problem, const std::string& path);

/// Captures the current EKF state and a scan (the offline runner's dump). Landmarks are written
/// in state order, so problem landmark k is ekf.landmarkIds()[k]. Throws std::invalid_argument
/// when the observations do not share one R.
AssociationProblem makeAssociationProblem(const EkfSlam& ekf, const RangeBearingModel& model,
                                          const std::vector<Observation>& observations);

/// Parameter values implied by the problem's alphas for the associator `name` ("DJNN" or
/// "ekf_slam/DJNN"): each gate probability parameter of that associator gets 1 - alpha:
///   NN, Hungarian:  individual_probability = 1 - chi2_alpha_individual
///   JCBB, NNJCBB:   individual_probability = 1 - chi2_alpha_individual,
///                   joint_probability      = 1 - chi2_alpha_joint
///   DJNN:           individual_probability = ambiguity_probability = 1 - chi2_alpha_individual
/// Empty when the problem sets no alpha.
std::vector<std::pair<std::string, std::string>> problemParameters(
    const AssociationProblem& problem, const std::string& name);

struct ReplayResult {
  AssociationResult result;   ///< as returned by the associator (ids = landmark indices)
  std::vector<int> landmark;  ///< per observation: problem landmark index, -1 if unpaired
  std::vector<std::pair<int, int>> pairs;  ///< (observation, landmark index) of the pairings
  double joint_mahalanobis = 0.0;          ///< D^2 of `pairs` (0 when there are none)
};

/// Runs one associate() call of a configured associator on the problem: the EKF is set to the
/// problem's state with landmark ids 0..n-1 (so ids equal problem indices).
ReplayResult replayAssociation(const AssociationProblem& problem, DataAssociation& associator);

}  // namespace ekf_slam
