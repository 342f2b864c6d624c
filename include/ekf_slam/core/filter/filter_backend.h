// The filter a pipeline runs, chosen once: the full EKF, or the compressed EKF over it
// (filter: cekf, docs/cekf.md: the steps on the active area only, the same result up to
// rounding). Every step goes through here, so nothing else asks which one it is.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/compressed_ekf.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

class FilterBackend {
 public:
  /// `compressed`: the CEKF with `params` over the EKF; else the EKF alone.
  FilterBackend(bool compressed, const CompressedEkfParams& params) {
    if (compressed) cekf_ = std::make_unique<CompressedEkf>(&ekf_, params);
  }
  // The CEKF holds the EKF's address.
  FilterBackend(const FilterBackend&) = delete;
  FilterBackend& operator=(const FilterBackend&) = delete;

  /// The EKF's state. With the CEKF, its pose, correction states and active landmarks are
  /// current; the rest after flush().
  EkfSlam& ekf() { return ekf_; }
  const EkfSlam& ekf() const { return ekf_; }
  CompressedEkf* compressed() { return cekf_.get(); }
  const CompressedEkf* compressed() const { return cekf_.get(); }

  void predict(const MotionStep& step) {
    if (cekf_) {
      cekf_->predict(step);
    } else {
      ekf_.predict(step);
    }
  }
  bool update(const std::vector<Pairing>& pairings, const RangeBearingModel& model, double* nis) {
    return cekf_ ? cekf_->update(pairings, model, nis) : ekf_.update(pairings, model, nis);
  }
  LandmarkId addLandmark(const Eigen::Vector2d& z, const Eigen::Matrix2d& R,
                         const RangeBearingModel& model, MeasurementKind kind) {
    return cekf_ ? cekf_->addLandmark(z, R, model, kind) : ekf_.addLandmark(z, R, model, kind);
  }
  bool removeLandmark(LandmarkId id) {
    return cekf_ ? cekf_->removeLandmark(id) : ekf_.removeLandmark(id);
  }
  /// Brings the whole state up to date (a global update when an area is open).
  void flush() {
    if (cekf_) cekf_->flush();
  }
  /// Before associating around `center`: true when a landmark outside the active area lay within
  /// `radius` and everything was brought up to date (the index must then be synced again).
  bool prepare(const LandmarkIndex& index, const Eigen::Vector2d& center, double radius) {
    return cekf_ && cekf_->prepare(index, center, radius);
  }
  /// After the EKF was reset or replaced: the compressed filter starts again.
  void restart() {
    if (cekf_) cekf_->reset();
  }
  void setReach(double reach) {
    if (cekf_) cekf_->setReach(reach);
  }

 private:
  EkfSlam ekf_;
  std::unique_ptr<CompressedEkf> cekf_;
};

}  // namespace ekf_slam
