// The Victoria Park relocalisation experiment of seed 001 paper 2 (ALGORITHMS.md section 6), as a
// tool:
//
//   rosrun ekf_slam relocalisation_experiment --bag B --params P --map-scans 0:1000
//       --test-scans 1000:2500 --relocaliser ekf_slam/FGCBB --out DIR      (one line)
//
// One normal run of the pipeline through the bag (the offline runner, no relocaliser) gives the
// map as it stands after the last map scan and, for every test scan, its observations and the
// tracked pose, the reference. Then every test scan is relocalised alone in that map, without a
// prior, and compared with the reference. Writes DIR/scans.csv (one row per test scan) and
// DIR/summary.json, and prints the summary.
//
// A test scan is "inside the mapped area" when at least --inside-landmarks map landmarks lie
// within --range of the sensor at the reference pose and in its field of view; it has "enough
// observations" with at least --min-observations observations (all of the scan's trees). An answer
// is correct when found within 5 m and 0.2 rad of the reference pose (which has drifted from the
// map of the map scans since), else wrong. Found answers with a pairing that contradicts the
// reference run's (an observation the run paired with a map landmark paired with another) are
// counted apart (found_with_association_conflicts, scans.csv conflicts).
#pragma once

#include <cmath>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

namespace ekf_slam {

struct RelocalisationExperimentOptions {
  std::string bag_path;
  std::string params_path;  ///< pipeline and plugin parameters (config/victoria_park.yaml)
  std::string out_dir;
  std::string relocaliser = "ekf_slam/FGCBB";
  std::uint32_t map_begin = 0, map_end = 1000;  ///< [begin, end) 0-based scans
  std::uint32_t test_begin = 1000, test_end = 2500;
  double range = 16.0;          ///< R [m]: observations and landmarks counted within it
  double field_of_view = M_PI;  ///< of the sensor, for "inside" [rad]
  int inside_landmarks = 3;     ///< map landmarks in view for "inside the mapped area"
  int min_observations = 6;     ///< for "enough observations"
};

/// One test scan (a row of scans.csv).
struct ExperimentScan {
  std::uint32_t scan = 0;
  int observations = 0;  ///< trees extracted from the scan
  bool inside = false;
  std::string answer;    ///< found / not_found / ambiguous
  bool correct = false;  ///< found and near the reference
  int pairings = 0;
  int conflicts = 0;  ///< pairings with another map landmark than the reference run's
  int mapped = 0;     ///< observations the reference run paired with a landmark of the map
  double position_error_m = 0.0;   ///< NaN unless found
  double heading_error_rad = 0.0;  ///< NaN unless found
  double time_us = 0.0;
  std::uint64_t nodes = 0;
  std::string reason;
};

struct ExperimentSummary {
  std::size_t map_landmarks = 0;
  std::vector<ExperimentScan> scans;
  std::string json;  ///< summary.json
};

ExperimentSummary runRelocalisationExperiment(const RelocalisationExperimentOptions& options,
                                              std::ostream& log);
bool parseExperimentArguments(const std::vector<std::string>& args,
                              RelocalisationExperimentOptions* options, bool* help,
                              std::string* error);
/// The whole command; returns the exit code (0 ok, 1 run error, 2 bad arguments).
int relocalisationExperimentMain(int argc, char** argv);

}  // namespace ekf_slam
