// A joint hypothesis of a loop closure is, in effect, a pose correction: the mean world-frame
// offset of its paired observations' sources from their landmarks. Two DJNN extensions compare
// closures by it: held confirmations (held_confirmation.h: a lead must repeat) and closure
// evidence (closure_evidence.h: a correction must lead the sum of the held scans). The
// correction's covariance leaves the pose's own uncertainty out: that error is what the
// hypotheses disagree on, and consecutive scans share it (the odometry between two adds little).
// What remains is each observation's noise mapped to the world and its landmark's covariance
// (which cancels when two scans pair the same landmarks, so counting it errs on the safe side),
// averaged over the n pairs.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

struct PoseCorrection {
  bool paired = false;  ///< it pairs an observation with a landmark that counts
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();  ///< mean source - landmark, world frame
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();     ///< its covariance, the pose's left out
};

/// An observation's source in the world at the pose estimate, and its noise there.
struct CorrectionSource {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
};

/// The sources of `problem`'s observations (computed once per scan).
std::vector<CorrectionSource> correctionSources(const AssociationContext& ctx,
                                                const JointMlProblem& problem);

/// The correction `hypothesis` (per problem observation: a landmark state index, < 0 for none)
/// implies over the landmarks `counts` accepts; not paired when it pairs none of them.
PoseCorrection poseCorrection(const AssociationContext& ctx, const JointMlProblem& problem,
                              const std::vector<CorrectionSource>& sources,
                              const std::vector<int>& hypothesis,
                              const std::function<bool(int)>& counts);

/// Two corrections agree when neither pairs, or both do and they differ by at most `gate`
/// (chi2(2)) of the difference's covariance (the scans' noise is independent).
bool correctionsAgree(const PoseCorrection& a, const PoseCorrection& b, double gate);

}  // namespace ekf_slam
