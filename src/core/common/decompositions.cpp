#include "ekf_slam/core/common/decompositions.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace ekf_slam {

SymmetricEigen2 symmetricEigen(const Eigen::Matrix2d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(m);
  return {eig.eigenvalues(), eig.eigenvectors()};
}

Eigen::Vector2d symmetricEigenvalues(const Eigen::Matrix2d& m) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(m, Eigen::EigenvaluesOnly).eigenvalues();
}

std::optional<Eigen::Matrix3d> fullPivInverse(const Eigen::Matrix3d& a) {
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(a);
  if (!lu.isInvertible()) return std::nullopt;
  return Eigen::Matrix3d(lu.inverse());
}

std::optional<Eigen::Vector3d> fullPivSolve(const Eigen::Matrix3d& a, const Eigen::Vector3d& b) {
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(a);
  if (!lu.isInvertible()) return std::nullopt;
  return Eigen::Vector3d(lu.solve(b));
}

Eigen::Vector3d ldltSolve(const Eigen::Matrix3d& a, const Eigen::Vector3d& b) {
  return a.ldlt().solve(b);
}

}  // namespace ekf_slam
