// DJNN's held window (docs/djnn.md, "Deciding a held closure on the held scans"): while the joint
// decision holds a loop closure, the filter runs on odometry only and every held scan is evidence
// about the same closure. The held scans are kept (a ScanWindow, carried by the odometry) and a
// hypothesis of the current scan is weighed with the held scans' best explanation given it, in one
// joint Gaussian over the current filter: the prior counted once, each held scan's observations at
// the pose they were seen from.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/scan_window.h"

namespace ekf_slam {

/// One pairing of the window: observation z (with noise R, of `kind`) seen from window scan `scan`
/// (index into HeldWindow::scans(), oldest first; -1 = the current scan) with landmark state index
/// `landmark`, at `cost` (-2 ln, >= 0) on top of its likelihood.
struct WindowPairing {
  int scan = -1;
  int landmark = -1;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  MeasurementKind kind = MeasurementKind::kCartesian;
  double cost = 0.0;
};

/// The held scans of a closure. Between two scans of a held closure the filter only predicts (the
/// window is cleared on any correction), so the odometry between them is read off the estimate:
/// F from the pose change, Q = P - F P_prev F^T.
class HeldWindow {
 public:
  /// One way a held observation could be explained, as weighed when it was held: paired with
  /// `landmark`, as observation `z` (the observation itself, or a virtual one for a feature
  /// anchored to that landmark: DJNN's remembered and live tentative features), at `cost`;
  /// exclusive within its scan under `key`.
  struct Option {
    LandmarkId landmark = kNoLandmark;
    Observation z;
    double cost = 0.0;
    std::int64_t key = 0;
  };
  /// A held observation and its options.
  struct Held {
    Observation observation;
    std::vector<Option> options;
  };

  explicit HeldWindow(int size = 0) : window_(size) {}
  int size() const { return window_.size(); }
  bool empty() const { return window_.empty(); }
  void clear();
  /// The pose estimate and its covariance at a new scan (call at every scan). Returns false, and
  /// clears the window, when the change since the last scan is not a prediction's (a correction
  /// the window was not told of).
  bool advance(const Eigen::Vector3d& pose, const Eigen::Matrix3d& P);
  /// Keeps the held observations of scan `scan`, seen from the estimate `pose` (the oldest beyond
  /// size() scans are dropped).
  void push(std::uint32_t scan, const Eigen::Vector3d& pose, const std::vector<Held>& held);
  /// The held scans, oldest first: pose, Q (the current pose's covariance given that pose) and
  /// observations; held(k) of the same index.
  const std::vector<CarriedScan>& scans(const Eigen::Vector3d& now);
  const std::vector<Held>& held(int k) const { return held_.at(scans_[k].scan); }

 private:
  ScanWindow window_;
  std::map<std::uint32_t, std::vector<Held>> held_;
  std::vector<CarriedScan> scans_;
  bool have_last_ = false;
  Eigen::Vector3d last_pose_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d last_P_ = Eigen::Matrix3d::Zero();
};

/// The joint Gaussian of window pairings over the current filter, built pairing by pairing (chain
/// rule): each pairing's cost given the ones added before. A pairing of held scan k is predicted
/// from the pose estimate at k; its pose error is F_k^-1 (e_now - w_k), w_k the odometry noise
/// since k (covariance Q_k, part of the current pose's error), so that
/// cov(e_k, e_l) = F_k^-1 (P_now - Q_older) F_l^-T and cov(e_k, m) = F_k^-1 P_now,m.
class WindowLikelihood {
 public:
  WindowLikelihood(const EkfSlam& ekf, const RangeBearingModel& model,
                   const std::vector<CarriedScan>& scans);
  /// -2 ln N(v; 0, S) of `p` given the pairings added (its own cost included); infinite when S is
  /// not positive definite. `mahalanobis`: its conditional v^T S^-1 v.
  double conditionalCost(const WindowPairing& p, double* mahalanobis = nullptr) const;
  /// Adds `p`; returns its conditional cost (as conditionalCost).
  double add(const WindowPairing& p);
  int pairings() const { return static_cast<int>(rows_.size()); }

 private:
  struct Row {
    int scan;
    int row;      ///< the landmark's state row
    Matrix23d G;  ///< d h / d current pose: H_pose(pose_k) F_k^-1
    Eigen::Matrix2d Hm;
    Eigen::Vector2d v;
    Eigen::Matrix2d R;
    double cost;
  };
  Row linearise(const WindowPairing& p) const;
  Eigen::Matrix2d cross(const Row& a, const Row& b) const;
  /// Conditional innovation and covariance of `a`; W = L^-1 S_Ba.
  bool condition(const Row& a, Eigen::Vector2d* v, Eigen::Matrix2d* S, Eigen::MatrixXd* W) const;

  const EkfSlam& ekf_;
  const RangeBearingModel& model_;
  const std::vector<CarriedScan>& scans_;
  std::vector<Eigen::Matrix3d> Finv_;  ///< per held scan
  std::vector<Row> rows_;
  Eigen::MatrixXd L_;  ///< lower Cholesky factor of the added pairings' joint S
  Eigen::VectorXd y_;  ///< L^-1 v
};

}  // namespace ekf_slam
