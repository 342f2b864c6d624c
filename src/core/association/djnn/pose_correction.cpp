#include "ekf_slam/core/association/djnn/pose_correction.h"

#include <Eigen/LU>

namespace ekf_slam {

std::vector<CorrectionSource> correctionSources(const AssociationContext& ctx,
                                                const JointMlProblem& problem) {
  std::vector<CorrectionSource> src(problem.obs.size());
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const Observation& o = ctx.observations()[problem.obs[k]];
    Matrix23d G_pose;
    Eigen::Matrix2d G_obs;
    src[k].point = ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
    src[k].cov = G_obs * o.R * G_obs.transpose();
  }
  return src;
}

PoseCorrection poseCorrection(const AssociationContext& ctx, const JointMlProblem& problem,
                              const std::vector<CorrectionSource>& sources,
                              const std::vector<int>& hypothesis,
                              const std::function<bool(int)>& counts) {
  PoseCorrection c;
  int n = 0;
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const int j = hypothesis[k];
    if (j < 0 || !counts(j)) continue;  // no map landmark, or one that does not count
    c.offset += sources[k].point - ctx.ekf().landmark(j);
    c.cov += sources[k].cov + ctx.ekf().landmarkCovariance(j);
    ++n;
  }
  c.paired = n > 0;
  if (n > 0) {
    c.offset /= n;
    c.cov /= static_cast<double>(n) * n;
  }
  return c;
}

bool correctionsAgree(const PoseCorrection& a, const PoseCorrection& b, double gate) {
  if (a.paired != b.paired) return false;
  if (!a.paired) return true;
  const Eigen::Vector2d e = a.offset - b.offset;
  return e.dot((a.cov + b.cov).inverse() * e) <= gate;
}

}  // namespace ekf_slam
