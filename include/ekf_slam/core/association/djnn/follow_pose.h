// DJNN extension "tentative features follow the pose" (tentative_follow_pose; docs/djnn.md,
// "Tentative features and the pose error"): a tentative feature is placed from the pose estimate
// of its sightings, so its error is that pose's error. When an update corrects the pose, a
// landmark initialised from it would move along (its cross-covariance with the pose is
// G_x P_vv); the features within reach of the sensor follow the same rigid motion, and the gate
// of a new sighting then leaves the pose error out (common to both), keeping only the heading
// error's share that differs with the lever.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

class FollowPose {
 public:
  struct Params {
    bool tentative_follow_pose = false;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }

  /// The sighting's covariance for the gate with a tentative feature: the observation noise
  /// plus, unless the features follow the pose, the pose covariance once; *lever_var the heading
  /// variance for the lever difference (following only).
  Eigen::Matrix2d gateCovariance(const Eigen::Matrix2d& cov_obs, const Matrix23d& G_pose,
                                 const Eigen::Matrix3d& P_vv, double* lever_var) const;
  /// The update moved the pose from `prior` to `posterior`: the features within `reach` of the
  /// prior pose move with it.
  void poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior, double reach,
                     TentativeSet* tentatives);

 private:
  Params p_;
  std::vector<int> near_;
};

}  // namespace ekf_slam
