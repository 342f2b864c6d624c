// Eigen's decompositions of the small fixed-size matrices the estimator uses, compiled once in
// src/core/common/decompositions.cpp. Each one costs 5-10 s of compile time in every file that
// instantiates it; the results are the same as calling Eigen in place.
#pragma once

#include <optional>

#include <Eigen/Core>

namespace ekf_slam {

/// Eigenvalues (ascending) and eigenvectors (columns) of a symmetric 2x2 matrix
/// (Eigen::SelfAdjointEigenSolver).
struct SymmetricEigen2 {
  Eigen::Vector2d values;
  Eigen::Matrix2d vectors;
};
SymmetricEigen2 symmetricEigen(const Eigen::Matrix2d& m);
/// The eigenvalues alone (ascending; Eigen::EigenvaluesOnly).
Eigen::Vector2d symmetricEigenvalues(const Eigen::Matrix2d& m);

/// a^-1 by full-pivoting LU (Eigen::FullPivLU); nothing when a is not invertible.
std::optional<Eigen::Matrix3d> fullPivInverse(const Eigen::Matrix3d& a);
/// x = a^-1 b by full-pivoting LU; nothing when a is not invertible.
std::optional<Eigen::Vector3d> fullPivSolve(const Eigen::Matrix3d& a, const Eigen::Vector3d& b);

/// x = a^-1 b by LDLT (Eigen::LDLT, a symmetric), without a check of the factorisation.
Eigen::Vector3d ldltSolve(const Eigen::Matrix3d& a, const Eigen::Vector3d& b);

}  // namespace ekf_slam
