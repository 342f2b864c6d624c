// Noise calibration from a bag (docs/calibration.md):
//
//   rosrun ekf_slam calibrate_noise --bag B --params P --out DIR [--runs N] [--set NAME=VALUE ...]
//
// Runs the bag through the offline runner (the package as it is, with P), smooths the run and
// estimates the factor of each noise term (core/smoothing/noise_calibration.h); then runs again
// with the scaled values, until a run's factors are all within --tolerance of 1 or --runs runs
// were made (the filter's pairings change with its noise, so one smoothing is not the end). Then
// one run with the final values gives the "after" figures. Writes DIR/calibrated_noise.yaml (the
// parameters it changed, the names of the parameter file), DIR/run_K/ (each run's usual outputs)
// and DIR/calibration.json; prints the factors and the before / after NIS and chi-square figures.
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "ekf_slam/core/smoothing/noise_calibration.h"
#include "ekf_slam/ros/offline/offline_options.h"

namespace ekf_slam {

struct CalibrateNoiseOptions {
  std::string bag_path;
  std::string params_path;
  std::string out_dir;
  std::string associator;  ///< empty: the file's
  /// --set NAME=VALUE or SECTION/NAME=VALUE, over the file (e.g. deliberately wrong sigmas).
  std::vector<OfflineOptions::Override> overrides;
  int max_runs = 6;
  /// A run whose factors are all within this of 1 ends the calibration.
  double tolerance = 0.02;
  double min_dof = 100.0;  ///< NoiseCalibrationParams::min_dof
  bool progress = true;
};

/// The filter's normalised innovation squared over a run (every scan's batch update).
struct NisFigures {
  std::size_t scans = 0;       ///< scans with an update
  double mean_per_dof = 0.0;   ///< sum of NIS / sum of its dof (1 when consistent)
  double share_in_band = 0.0;  ///< scans whose NIS lies in chi2(dof)'s central 95 %
  double share_above = 0.0;    ///< ... above it
};

/// One run of the bag and the calibration of its smoothed residuals.
struct CalibrationRun {
  std::map<std::string, double> values;  ///< the noise parameters it ran with
  NisFigures nis;
  double gps_rmse_m = -1.0;        ///< < 0 without GPS
  double truth_pose_ate_m = -1.0;  ///< simulated bags: aligned pose ATE; < 0 otherwise
  double truth_anees = -1.0;       ///< simulated bags: the pose ANEES
  std::size_t landmarks = 0;
  NoiseCalibrationResult calibration;  ///< not ok for the final check run
};

struct CalibrateNoiseResult {
  std::vector<CalibrationRun> runs;             ///< the calibration runs, then the check run
  std::map<std::string, double> before, after;  ///< the noise parameters, as given and calibrated
  /// Per term, the factor of its standard deviations against the file (product over the runs).
  std::array<double, kNoiseTerms> factors{};
  /// Calibrated in at least one run; seen in some run but never calibrated (too few dof).
  std::array<bool, kNoiseTerms> calibrated{}, undetermined{};
  bool converged = false;
  std::string yaml;  ///< the snippet
};

/// The whole calibration. Throws as runOffline does (bag, parameters, output folder).
CalibrateNoiseResult calibrateNoiseOnBag(const CalibrateNoiseOptions& options, std::ostream& log);

bool parseCalibrateNoiseArguments(const std::vector<std::string>& args,
                                  CalibrateNoiseOptions* options, bool* help, std::string* error);
void printCalibrateNoiseUsage(std::ostream& out);
/// parse, run, print; exit code 0 ok, 1 run error, 2 bad arguments.
int calibrateNoiseMain(int argc, char** argv);

}  // namespace ekf_slam
