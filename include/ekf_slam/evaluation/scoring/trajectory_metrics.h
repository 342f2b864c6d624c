// Trajectory accuracy against a position reference (e.g. GPS), ROS-free: RMSE of the estimated
// positions at the reference stamps, raw and after the best rigid 2D alignment.
//
// The SLAM map frame is anchored at the start pose, the reference in its own frame (GPS: metres
// east/north), so only the aligned RMSE measures the shape of the trajectory; the unaligned one is
// reported for runs whose frames agree by construction (simulation).
#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

/// A position at a time.
struct StampedPoint {
  double stamp = 0.0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
};

/// A rotation by `yaw` followed by a translation: p' = R(yaw) p + translation.
struct RigidTransform2 {
  double yaw = 0.0;
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();

  Eigen::Matrix2d rotation() const;
  Eigen::Vector2d apply(const Eigen::Vector2d& p) const { return rotation() * p + translation; }
};

/// The rigid transform T minimising sum |to_i - T(from_i)|^2 (closed-form 2D Procrustes/Umeyama
/// without scale). Both lists have the same length; with fewer than two distinct points the
/// rotation is undetermined and left at 0 (pure translation between the centroids).
RigidTransform2 alignRigid2D(const std::vector<Eigen::Vector2d>& from,
                             const std::vector<Eigen::Vector2d>& to);

/// Position of a trajectory (sorted by stamp, strictly increasing) at `stamp`, linearly
/// interpolated between the two samples around it. Empty when `stamp` is outside the trajectory's
/// span or the two samples are more than `max_gap` seconds apart (a hole in the estimate).
std::optional<Eigen::Vector2d> interpolatePosition(const std::vector<StampedPoint>& trajectory,
                                                   double stamp, double max_gap);

struct TrajectoryErrorOptions {
  /// Reference points between two estimate samples further apart than this are not used [s].
  double max_interpolation_gap = 1.0;
};

struct TrajectoryError {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double rmse_aligned = kNaN;    ///< after alignRigid2D(estimate -> reference) [m]
  double rmse_unaligned = kNaN;  ///< in the frames as given [m]
  double max_aligned = kNaN;     ///< largest aligned error [m]
  /// Median and 95th percentile of the aligned errors [m]: unlike the RMSE, hardly moved by a
  /// few wild reference points (Victoria Park's GPS has some).
  double median_aligned = kNaN;
  double p95_aligned = kNaN;
  std::size_t points = 0;     ///< reference points used
  std::size_t skipped = 0;    ///< reference points outside the estimate / in its gaps / NaN
  RigidTransform2 alignment;  ///< maps estimate positions onto the reference frame
};

/// Compares `estimate` (sorted by stamp; unsorted input is sorted) with `reference` at the
/// reference stamps. Reference points the estimate does not cover are skipped, so gaps in either
/// (GPS outages, a late start) only reduce `points`. NaN RMSEs when no point is usable.
TrajectoryError compareTrajectories(std::vector<StampedPoint> estimate,
                                    const std::vector<StampedPoint>& reference,
                                    const TrajectoryErrorOptions& options = {});

/// A speed at a time (odometry), for the path length between two stamps.
struct StampedSpeed {
  double stamp = 0.0;
  double speed = 0.0;  ///< held until the next sample [m/s]
};

/// Faulty GPS fixes, decided from the GPS track and the odometry alone (never the estimate):
/// the odometry bounds how far the vehicle can have moved between two fixes, its path length
/// D = integral |v| dt (zero-order hold), so two fixes are consistent when
///   |g_b - g_a| <= (1 + path_tolerance) D(t_a, t_b) + distance_tolerance.
/// A run of at most max_run fixes is faulty when its first fix is inconsistent with the last good
/// fix before it and with the first fix after it, while those two neighbours are consistent with
/// each other: a jump out and back that no vehicle motion between its neighbours explains. A
/// jump that persists longer is not judged (the track is accepted from there: without the
/// estimate one cannot tell which side of it is right). The first fix is taken as good.
struct GpsFaultOptions {
  double distance_tolerance = 3.0;  ///< [m]: GPS noise and the odometry's resolution
  double path_tolerance = 0.2;      ///< fraction of the path: odometry scale error
  int max_run = 20;                 ///< longest excursion judged faulty [fixes]
};

/// One flag per fix of `gps` (sorted by stamp): true = faulty. `odometry` sorted by stamp; GPS
/// stamps outside its span use the nearest speed.
std::vector<bool> faultyGpsFixes(const std::vector<StampedPoint>& gps,
                                 const std::vector<StampedSpeed>& odometry,
                                 const GpsFaultOptions& options = {});

}  // namespace ekf_slam
