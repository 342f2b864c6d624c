#include "ekf_slam/tools/relocalisation_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include <nlohmann/json.hpp>

#include "ekf_slam/app/command_line.h"
#include "ekf_slam/app/output_files.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/evaluation/scoring/run_scorer.h"  // kWrongRelocalisationAngle
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {

namespace {

// What the normal run leaves for one test scan.
struct TestInput {
  std::uint32_t scan;
  std::vector<Observation> observations;
  Eigen::Vector3d reference;
  std::vector<LandmarkId> paired;  // the run's pairing of each observation, or kNoLandmark
};

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// A found pose farther than this from the reference is wrong [m] (or turned more than
// kWrongRelocalisationAngle).
constexpr double kMaxPositionError = 5.0;

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

bool parseRange(const std::string& v, std::uint32_t* begin, std::uint32_t* end) {
  unsigned long a = 0, b = 0;
  int used = 0;
  if (std::sscanf(v.c_str(), "%lu:%lu%n", &a, &b, &used) != 2 ||
      used != static_cast<int>(v.size()) || v[0] == '-' || a >= b || b > 0xffffffffUL)
    return false;
  *begin = static_cast<std::uint32_t>(a);
  *end = static_cast<std::uint32_t>(b);
  return true;
}

}  // namespace

ExperimentSummary runRelocalisationExperiment(const RelocalisationExperimentOptions& o,
                                              std::ostream& log) {
  if (o.out_dir.empty()) throw std::runtime_error("no output folder given (--out DIR)");
  // The relocaliser first: a wrong name or parameter fails before the run. The whole file is
  // checked as every entry point checks it (app/pipeline_builder.h).
  YamlConfiguration configuration(o.params_path);
  configuration.setOverride("", "relocaliser", o.relocaliser);
  const std::shared_ptr<Relocaliser> relocaliser =
      buildPipeline(configuration, PluginlibFactory()).relocaliser;

  // 1. The normal run: the map after the map scans, the test scans and their reference poses.
  makeDirectory(o.out_dir);
  OfflineOptions run;
  run.bag_path = o.bag_path;
  run.params_path = o.params_path;
  run.out_dir = o.out_dir + "/reference_run";
  run.plot = false;
  run.progress = false;
  std::vector<MapLandmark> map;
  std::vector<TestInput> tests;
  Eigen::Vector3d sensor_offset = Eigen::Vector3d::Zero();
  run.on_scan = [&](const ScanReport& r, const SlamPipeline& p) {
    if (r.scan + 1 == o.map_end) map = p.mapLandmarks();
    if (r.scan >= o.test_begin && r.scan < o.test_end) {
      std::vector<LandmarkId> paired(r.observations.size(), kNoLandmark);
      for (std::size_t i = 0; i < paired.size() && i < r.association.decision.size(); ++i) {
        if (r.association.decision[i] == Decision::kPaired) paired[i] = r.association.landmark[i];
      }
      tests.push_back({r.scan, r.observations, p.pose(), std::move(paired)});
    }
    sensor_offset = p.sensorOffset();
  };
  const OfflineSummary reference = runOffline(run, log);
  if (map.empty()) {
    throw std::runtime_error("the run has " + std::to_string(reference.scans) +
                             " scans: no map after scan " + std::to_string(o.map_end));
  }
  relocaliser->setMap(map);
  std::set<LandmarkId> in_map;
  for (const MapLandmark& l : map) in_map.insert(l.id);
  log << "map after scan " << o.map_end << ": " << map.size() << " landmarks; " << tests.size()
      << " test scans\n";

  // 2. Every test scan alone, no prior.
  ExperimentSummary summary;
  summary.map_landmarks = map.size();
  const RangeBearingModel model(sensor_offset);
  for (const TestInput& t : tests) {
    ExperimentScan s;
    s.scan = t.scan;
    s.observations = static_cast<int>(t.observations.size());
    for (const LandmarkId id : t.paired) s.mapped += id != kNoLandmark && in_map.count(id) > 0;
    const Eigen::Vector3d sensor = model.sensorPose(t.reference);
    int in_view = 0;
    for (const MapLandmark& l : map) {
      const Eigen::Vector2d d = l.position - sensor.head<2>();
      in_view +=
          d.norm() <= o.range &&
          std::abs(wrapAngle(std::atan2(d.y(), d.x()) - sensor.z())) <= 0.5 * o.field_of_view;
    }
    s.inside = in_view >= o.inside_landmarks;
    const auto t0 = std::chrono::steady_clock::now();
    const RelocalisationResult r = relocaliser->relocalise(t.observations, sensor_offset, nullptr);
    s.time_us = 1e6 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    s.answer = toString(r.status);
    s.nodes = r.nodes;
    s.reason = r.reason;
    s.position_error_m = s.heading_error_rad = std::numeric_limits<double>::quiet_NaN();
    if (r.status == RelocalisationStatus::kFound) {
      s.pairings = r.hypothesis_size;
      s.position_error_m = (r.pose.head<2>() - t.reference.head<2>()).norm();
      s.heading_error_rad = std::abs(wrapAngle(r.pose.z() - t.reference.z()));
      // Pairings with another map landmark than the reference run's, reported apart: the run's
      // own association is no ground truth (two trees a metre apart, a late DJNN decision).
      for (std::size_t i = 0; i < r.landmark.size() && i < t.paired.size(); ++i) {
        s.conflicts += r.landmark[i] != kNoLandmark && t.paired[i] != kNoLandmark &&
                       in_map.count(t.paired[i]) > 0 && r.landmark[i] != t.paired[i];
      }
      // The reference has drifted from the map of the map scans since: metres, not tens.
      s.correct = s.position_error_m <= kMaxPositionError &&
                  s.heading_error_rad <= kWrongRelocalisationAngle;
    }
    summary.scans.push_back(s);
  }

  // 3. Files.
  {
    std::ofstream csv = openOutput(o.out_dir + "/scans.csv");
    csv << "scan,observations,mapped,inside,answer,correct,pairings,conflicts,position_error_m,"
           "heading_error_rad,time_us,nodes,reason\n";
    for (const ExperimentScan& s : summary.scans) {
      csv << s.scan << ',' << s.observations << ',' << s.mapped << ',' << s.inside << ','
          << s.answer << ',' << s.correct << ',' << s.pairings << ',' << s.conflicts << ',';
      if (std::isfinite(s.position_error_m)) csv << s.position_error_m;
      csv << ',';
      if (std::isfinite(s.heading_error_rad)) csv << s.heading_error_rad;
      csv << ',' << s.time_us << ',' << s.nodes << ",\"" << s.reason << "\"\n";
    }
  }
  std::size_t inside = 0, enough = 0, correct = 0, wrong = 0, ambiguous = 0, not_found = 0,
              correct_enough = 0, correct_inside = 0, with_conflicts = 0;
  std::map<int, std::vector<double>> times;  // by observations within R
  std::vector<double> all_times;
  for (const ExperimentScan& s : summary.scans) {
    const bool found = s.answer == "found";
    inside += s.inside;
    const bool is_enough = s.inside && s.observations >= o.min_observations;
    enough += is_enough;
    correct += s.correct;
    wrong += found && !s.correct;
    ambiguous += s.answer == "ambiguous";
    not_found += s.answer == "not_found";
    correct_enough += is_enough && s.correct;
    with_conflicts += found && s.conflicts > 0;
    correct_inside += s.inside && s.correct;
    times[s.observations].push_back(s.time_us);
    all_times.push_back(s.time_us);
  }
  nlohmann::json j;
  j["relocaliser"] = pluginShortName(o.relocaliser);
  j["bag"] = o.bag_path;
  j["params"] = o.params_path;
  j["map_scans"] = {o.map_begin, o.map_end};
  j["test_scans"] = {o.test_begin, o.test_end};
  j["range_m"] = o.range;
  j["map_landmarks"] = map.size();
  j["tested"] = summary.scans.size();
  j["inside_map"] = inside;
  j["enough_observations"] = enough;
  j["correct"] = correct;
  j["correct_inside_map"] = correct_inside;
  j["correct_enough_observations"] = correct_enough;
  j["correct_rate_enough_observations"] =
      number(enough > 0 ? static_cast<double>(correct_enough) / enough : NAN);
  j["wrong"] = wrong;
  j["found_with_association_conflicts"] = with_conflicts;
  j["ambiguous"] = ambiguous;
  j["not_found"] = not_found;
  j["median_time_us"] = number(median(all_times));
  nlohmann::json by = nlohmann::json::object();
  for (const auto& [n, v] : times)
    by[std::to_string(n)] = {{"calls", v.size()}, {"median_us", median(v)}};
  j["median_time_us_by_observations"] = by;
  j["reference_run_gps_rmse_m"] = number(reference.gps_rmse_m);
  summary.json = j.dump(2) + "\n";
  openOutput(o.out_dir + "/summary.json") << summary.json;
  return summary;
}

bool parseExperimentArguments(const std::vector<std::string>& args,
                              RelocalisationExperimentOptions* o, bool* help, std::string* error) {
  CommandLine cl(args);
  std::string v;
  // The value of a flag that takes a positive number.
  const auto number = [&](double* out) {
    if (!cl.value(&v)) return false;
    char* end = nullptr;
    *out = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !(*out > 0.0)) {
      return cl.fail(cl.flag() + " needs a positive number, got '" + v + "'");
    }
    return true;
  };
  double x = 0.0;
  while (cl.next()) {
    if (cl.is("--bag")) {
      cl.value(&o->bag_path);
    } else if (cl.is("--params")) {
      cl.value(&o->params_path);
    } else if (cl.is("--out")) {
      cl.value(&o->out_dir);
    } else if (cl.is("--relocaliser")) {
      if (cl.value(&v)) o->relocaliser = v;
    } else if (cl.is("--map-scans") || cl.is("--test-scans")) {
      const bool map = cl.is("--map-scans");
      if (!cl.value(&v)) break;
      if (!parseRange(v, map ? &o->map_begin : &o->test_begin, map ? &o->map_end : &o->test_end)) {
        cl.fail(cl.flag() + " needs FIRST:END (0-based, END excluded, FIRST < END), got '" + v +
                "'");
      }
    } else if (cl.is("--range")) {
      number(&o->range);
    } else if (cl.is("--field-of-view")) {
      number(&o->field_of_view);
    } else if (cl.is("--inside-landmarks") || cl.is("--min-observations")) {
      if (!number(&x)) break;
      if (x != std::floor(x)) {
        cl.fail(cl.flag() + " needs a positive integer, got '" + v + "'");
        break;
      }
      (cl.is("--inside-landmarks") ? o->inside_landmarks : o->min_observations) =
          static_cast<int>(x);
    } else {
      cl.unknown();
    }
  }
  if (!cl.finish(help, error)) return false;
  if (*help) return true;
  if (o->bag_path.empty() || o->out_dir.empty()) {
    *error = "--bag and --out are required";
    return false;
  }
  if (o->map_begin != 0) {
    *error = "--map-scans must start at 0: the map is the one the run has built by its END";
    return false;
  }
  return true;
}

int relocalisationExperimentMain(int argc, char** argv) {
  const char* usage =
      "usage: relocalisation_experiment --bag FILE --out DIR [--params YAML]\n"
      "       [--map-scans 0:1000] [--test-scans 1000:2500] [--relocaliser ekf_slam/FGCBB]\n"
      "       [--range 30] [--field-of-view 3.14159] [--inside-landmarks 3]\n"
      "       [--min-observations 6]\n"
      "Builds the map with the pipeline on the map scans, then relocalises every test scan\n"
      "alone without prior and compares it with the tracked pose of the same run. Writes\n"
      "DIR/scans.csv and DIR/summary.json (docs/relocalisation.md).\n";
  RelocalisationExperimentOptions o;
  bool help = false;
  std::string error;
  if (!parseExperimentArguments(std::vector<std::string>(argv + 1, argv + argc), &o, &help,
                                &error)) {
    std::cerr << "relocalisation_experiment: " << error << "\n" << usage;
    return 2;
  }
  if (help) {
    std::cout << usage;
    return 0;
  }
  try {
    const ExperimentSummary s = runRelocalisationExperiment(o, std::cerr);
    std::cout << s.json << "wrote " << o.out_dir << "/{scans.csv,summary.json}\n";
  } catch (const std::exception& e) {
    std::cerr << "relocalisation_experiment: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace ekf_slam
