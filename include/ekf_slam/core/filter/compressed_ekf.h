// Compressed EKF (Guivant & Nebot 2001, "Optimization of the simultaneous localization and
// map-building algorithm for real-time implementation", IEEE T-RA 17(3)). ROS-free (Eigen only).
//
// The map is split into the active part A (vehicle states plus the landmarks around the area the
// vehicle is in) and the rest B. While the vehicle stays in its area, observations involve only A
// and the prediction only the vehicle, so the EKF on A alone is exact for A; what the steps do to
// P_AB, P_BB and x_B is a function of three accumulated matrices (phi, psi, theta) of A's size,
// applied in one global update when the vehicle leaves the area or the whole state is needed.
// The result equals the full EKF's up to rounding. Derivation and choices: docs/cekf.md.
//
// CompressedEkf works on an EkfSlam that holds the whole state (the "global" filter, e.g. the
// pipeline's): between global updates its pose and A entries are current (the associators read
// them there, unchanged), its B entries are stale. The steps on A run in a private EkfSlam whose
// state is [vehicle, A landmarks, phantom states Z]: Z starts with cov(A, Z) = I, cov(Z, Z) = 0,
// mean 0, so that the ordinary EKF steps make cov(A, Z) = phi, -cov(Z, Z) = psi and x_Z = theta.
#pragma once

#include <cstdint>
#include <limits>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"

namespace ekf_slam {

struct CompressedEkfParams {
  /// Length of the stretch ahead of the vehicle (from its position and heading when an area
  /// opens) whose surroundings form A: every landmark within reach + margin of that segment [m].
  double area_size = 50.0;
  /// A landmark outside A within reach + margin of the sensor forces a global update [m].
  double margin = 10.0;
  /// A also holds the landmarks up to this much farther from the stretch than reach + margin:
  /// room for the pose estimate to move against the map (loop-closure corrections, the path
  /// leaving the straight line) before a landmark outside A comes within the rule-1 radius [m].
  double slack = 0.0;
  /// Farthest a landmark the associators read lies from the vehicle: observation range plus the
  /// sensor's offset [m].
  double reach = 30.0;
};

/// Why a compressed area was closed by a global update (docs/cekf.md, rules 1-4).
enum class CekfClosureReason {
  kGrown,            ///< rule 2: A grew past kGrowth its size at the opening
  kLandmarkInReach,  ///< rule 1: a landmark of B within reach + margin of the sensor
  kPairingOutside,   ///< rule 3: an update paired a landmark of B
  kFlush,            ///< rule 4: the whole state was asked for
};
const char* toString(CekfClosureReason reason);

/// One global update, as logged by CompressedEkf::setClosureLog (where and why areas close).
struct CekfClosure {
  CekfClosureReason reason = CekfClosureReason::kFlush;
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();    ///< the vehicle's at the closure
  Eigen::Vector3d opened = Eigen::Vector3d::Zero();  ///< the vehicle's when the area opened
  /// The landmark of B that closed it (rules 1 and 3, its stale estimate), else NaN.
  Eigen::Vector2d trigger = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  int opened_states = 0;      ///< A's states at the opening (the global update's rank)
  int active_states = 0;      ///< A's states at the closure
  std::size_t states = 0;     ///< the whole state's size N
  std::uint64_t updates = 0;  ///< updates run on A in this area
};

/// What the compressed filter did (over its life).
struct CompressedEkfStats {
  std::uint64_t phases = 0;             ///< areas opened (compressed or not)
  std::uint64_t compressed_phases = 0;  ///< of them, compressed (B at least as large as A)
  std::uint64_t global_updates = 0;     ///< compressed phases closed by a global update
  std::uint64_t grown = 0;              ///< ... because A grew past kGrowth its opening size
  std::uint64_t landmark_in_reach = 0;  ///< ... because a landmark of B came within reach
  std::uint64_t pairing_outside = 0;    ///< ... because an update paired a landmark of B
  std::uint64_t flushes = 0;            ///< ... because the whole state was asked for
  double global_update_s = 0.0;         ///< wall time of the global updates
  double global_update_flops = 0.0;     ///< their arithmetic (N^2 n_A + 2 n_A^2 N)
  std::size_t max_active_states = 0;    ///< largest A (vehicle + landmark states)
};

class CompressedEkf {
 public:
  /// `global` holds the whole state and outlives this object; nothing is compressed until the
  /// first step.
  CompressedEkf(EkfSlam* global, const CompressedEkfParams& params);

  const CompressedEkfParams& params() const { return p_; }
  const CompressedEkfStats& stats() const { return stats_; }
  /// Flops of the EKF updates on A (the private filter's UpdateStats), over the filter's life.
  double activeUpdateFlops() const { return local_.updateStats().flops; }
  /// Appends one record per global update to `log` (null: none); `log` outlives this object.
  void setClosureLog(std::vector<CekfClosure>* log) { log_ = log; }
  /// The sensing reach (observation range plus the sensor's offset) for the next areas [m].
  void setReach(double reach) { p_.reach = reach; }

  /// The EkfSlam steps, on A (opening an area around the vehicle when none is open). A pairing
  /// with a landmark outside A closes the phase first and opens one that includes it.
  bool predict(const MotionStep& step);
  bool update(const std::vector<Pairing>& pairings, const RangeBearingModel& model,
              double* nis = nullptr);
  LandmarkId addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                         const RangeBearingModel& model,
                         MeasurementKind kind = MeasurementKind::kRangeBearing);
  bool removeLandmark(LandmarkId id);

  /// Before a scan is associated, with the spatial index synced to the global filter: closes the
  /// phase (global update) when a landmark outside A lies within `radius` of `sensor`, or when A
  /// has grown past kGrowth its size at the opening. Returns true when it changed the global
  /// filter's B entries.
  bool prepare(const LandmarkIndex& index, const Eigen::Vector2d& sensor, double radius);
  /// Global update: the global filter becomes the full EKF's state; no phase is open after it.
  void flush();
  /// Forgets the phase without a global update (after the global filter was reset or replaced).
  void reset();

  /// True while a compressed phase is open (the global filter's B entries are stale).
  bool compressed() const { return open_ && compressed_; }
  /// A landmark of the open compressed phase's A.
  bool active(LandmarkId id) const { return compressed() && active_.count(id) > 0; }

 private:
  void ensurePhase();
  /// Opens an area centred on the vehicle; `extra` landmarks join A whatever their position.
  void openPhase(const std::vector<LandmarkId>& extra = {});
  /// Global update (compressed phase) and closes the phase; `trigger`: the landmark of B that
  /// made it necessary (rules 1 and 3), for the log.
  void closePhase(CekfClosureReason reason, const Eigen::Vector2d* trigger = nullptr);
  /// Global rows of the private filter's real (non-phantom) states, in order (both orders agree).
  void mapRows();
  /// Copies the private filter's real states (mean and covariance) into the global filter;
  /// vehicle rows only after a prediction.
  void scatter(bool vehicle_only);
  bool isPhantom(LandmarkId id) const { return id >= kPhantomBase; }

  static constexpr LandmarkId kPhantomBase = LandmarkId(1) << 60;
  // A compressed area closes when A has more than kGrowth times its states at the opening plus
  // kGrowthSlack (new landmarks while exploring).
  static constexpr int kGrowth = 2;
  static constexpr int kGrowthSlack = 100;

  EkfSlam* g_;
  CompressedEkfParams p_;
  CompressedEkfStats stats_;
  bool open_ = false;
  bool compressed_ = false;
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();  // vehicle position at the opening
  Eigen::Vector3d opened_ = Eigen::Vector3d::Zero();  // vehicle pose at the opening
  std::uint64_t area_updates_ = 0;                    // updates on A since the opening
  std::vector<CekfClosure>* log_ = nullptr;
  std::unordered_set<LandmarkId> active_;
  EkfSlam local_;
  int vehicle_ = 3;                // vehicle states (3 + correction states)
  int n_a0_ = 0;                   // A's states when the phase opened: the phantoms that matter
  Eigen::MatrixXd G_;              // cov(A0, B0) when the phase opened, n_a0 x 2 |B0|
  std::vector<LandmarkId> b_ids_;  // B0's landmarks, G_'s column pairs
  std::vector<int> local_rows_, global_rows_;  // real states: private row -> global row
  bool rows_dirty_ = true;
  std::vector<int> near_;  // prepare()'s query
};

}  // namespace ekf_slam
