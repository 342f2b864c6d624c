#include "ekf_slam/core/association/djnn/follow_pose.h"

#include <algorithm>

#include <Eigen/Geometry>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

void FollowPose::read(const ParameterReader& r) {
  p_.tentative_follow_pose = r.flag("tentative_follow_pose", Params().tentative_follow_pose);
}

Eigen::Matrix2d FollowPose::gateCovariance(const Eigen::Matrix2d& cov_obs, const Matrix23d& G_pose,
                                           const Eigen::Matrix3d& P_vv, double* lever_var) const {
  *lever_var = p_.tentative_follow_pose ? std::max(0.0, P_vv(2, 2)) : 0.0;
  return p_.tentative_follow_pose ? cov_obs : (cov_obs + G_pose * P_vv * G_pose.transpose()).eval();
}

void FollowPose::poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior,
                               double reach, TentativeSet* tentatives) {
  if (!p_.tentative_follow_pose || tentatives->empty()) return;
  const double dth = wrapAngle(posterior(2) - prior(2));
  const Eigen::Matrix2d Rot = Eigen::Rotation2Dd(dth).toRotationMatrix();
  tentatives->query(prior.head<2>(), reach, &near_);
  for (int slot : near_) {
    Tentative& t = (*tentatives)[slot];
    t.cov = Rot * t.cov * Rot.transpose();
    t.heading_lever = Rot * t.heading_lever;
    tentatives->move(slot, posterior.head<2>() + Rot * (t.position - prior.head<2>()));
  }
}

}  // namespace ekf_slam
