#include "ekf_slam/tools/calibrate_noise.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "ekf_slam/app/command_line.h"
#include "ekf_slam/app/output_files.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/ros/offline/offline_runner.h"

namespace ekf_slam {
namespace {

std::string number(double v, const char* format = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

// The parameters each noise term scales, with the names of the parameter file.
std::vector<std::string> keysOf(NoiseTerm term, const std::string& odometry_mode) {
  const bool twist = odometry_mode != "pose_delta";
  switch (term) {
    case NoiseTerm::kOdometryTranslation:
      return twist ? std::vector<std::string>{"twist_sigma_v", "twist_sigma_v_per_v"}
                   : std::vector<std::string>{"pose_delta_alpha_trans_per_trans",
                                              "pose_delta_alpha_trans_per_rot"};
    case NoiseTerm::kOdometryRotation:
      return twist ? std::vector<std::string>{"twist_sigma_w", "twist_sigma_w_per_v"}
                   : std::vector<std::string>{"pose_delta_alpha_rot_per_rot",
                                              "pose_delta_alpha_rot_per_trans"};
    case NoiseTerm::kRange:
      return {"sigma_range"};
    case NoiseTerm::kBearing:
      return {"sigma_bearing"};
    default:
      return {};  // the sensor's own covariance: no parameter of ours
  }
}

std::map<std::string, double> noiseValues(const PipelineConfig& c) {
  return {{"twist_sigma_v", c.twist.sigma_v},
          {"twist_sigma_v_per_v", c.twist.sigma_v_per_v},
          {"twist_sigma_w", c.twist.sigma_w},
          {"twist_sigma_w_per_v", c.twist.sigma_w_per_v},
          {"pose_delta_alpha_trans_per_trans", c.pose_delta.alpha_trans_per_trans},
          {"pose_delta_alpha_trans_per_rot", c.pose_delta.alpha_trans_per_rot},
          {"pose_delta_alpha_rot_per_rot", c.pose_delta.alpha_rot_per_rot},
          {"pose_delta_alpha_rot_per_trans", c.pose_delta.alpha_rot_per_trans},
          {"sigma_range", c.sigma_range},
          {"sigma_bearing", c.sigma_bearing}};
}

// Accumulates the filter's NIS per scan.
class NisCounter {
 public:
  void add(const ScanReport& r) {
    if (r.nis_dof <= 0 || !r.update_ok || !std::isfinite(r.nis)) return;
    auto it = band_.find(r.nis_dof);
    if (it == band_.end())
      it = band_
               .emplace(r.nis_dof, std::make_pair(chi2Quantile(0.025, r.nis_dof),
                                                  chi2Quantile(0.975, r.nis_dof)))
               .first;
    ++scans_;
    nis_ += r.nis;
    dof_ += r.nis_dof;
    in_ += r.nis >= it->second.first && r.nis <= it->second.second;
    above_ += r.nis > it->second.second;
  }
  NisFigures figures() const {
    NisFigures f;
    f.scans = scans_;
    if (scans_ == 0) return f;
    f.mean_per_dof = nis_ / static_cast<double>(dof_);
    f.share_in_band = static_cast<double>(in_) / static_cast<double>(scans_);
    f.share_above = static_cast<double>(above_) / static_cast<double>(scans_);
    return f;
  }

 private:
  std::map<int, std::pair<double, double>> band_;
  std::size_t scans_ = 0, in_ = 0, above_ = 0;
  double nis_ = 0.0;
  long dof_ = 0;
};

// One run of the bag with `noise` over the file, then (if asked) the calibration of its smoothed
// residuals.
CalibrationRun runOnce(const CalibrateNoiseOptions& opt, int index,
                       const std::map<std::string, double>& noise, bool calibrate,
                       std::string* odometry_mode, std::ostream& log) {
  OfflineOptions o;
  o.bag_path = opt.bag_path;
  o.params_path = opt.params_path;
  o.associator = opt.associator;
  o.out_dir = opt.out_dir + "/run_" + std::to_string(index);
  o.overrides = opt.overrides;
  for (const auto& [name, value] : noise) o.overrides.push_back({"", name, number(value, "%.17g")});
  o.plot = false;
  o.progress = opt.progress;
  SmoothingRecorder recorder;
  NisCounter nis;
  std::vector<SmoothingLandmark> landmarks;
  std::unique_ptr<RangeBearingModel> model;
  PipelineConfig config;
  o.on_scan = [&](const ScanReport& r, const SlamPipeline& pipeline) {
    recorder.add(r, pipeline);
    nis.add(r);
  };
  o.on_finish = [&](const SlamPipeline& pipeline) {
    landmarks = recorder.landmarks(pipeline);
    model = std::make_unique<RangeBearingModel>(pipeline.observationModel());
    config = pipeline.config();
  };
  std::ostringstream run_log;  // the runner's warnings: once, in the first run
  const OfflineSummary summary = runOffline(o, index == 0 ? log : run_log);

  CalibrationRun run;
  run.values = noiseValues(config);
  *odometry_mode = config.odometry_mode;
  run.nis = nis.figures();
  run.gps_rmse_m = summary.gps_rmse_m;
  run.landmarks = summary.landmarks;
  const nlohmann::json metrics = nlohmann::json::parse(summary.metrics_json);
  if (metrics.contains("truth")) {
    const nlohmann::json& t = metrics["truth"];
    if (t.contains("pose_ate_aligned_m") && t["pose_ate_aligned_m"].is_number())
      run.truth_pose_ate_m = t["pose_ate_aligned_m"].get<double>();
    if (t.contains("anees") && t["anees"].is_number()) run.truth_anees = t["anees"].get<double>();
  }
  if (calibrate) {
    NoiseCalibrationParams p;
    p.sigma_range = config.sigma_range;
    p.sigma_bearing = config.sigma_bearing;
    p.min_dof = opt.min_dof;
    run.calibration = calibrateNoise(recorder.scans(), landmarks, *model, p);
    if (!run.calibration.ok)
      throw std::runtime_error("run " + std::to_string(index) +
                               ": smoothing failed: " + run.calibration.error);
  }
  return run;
}

std::string snippet(const CalibrateNoiseOptions& opt, const CalibrateNoiseResult& r,
                    const std::string& mode) {
  std::ostringstream y;
  y << "# calibrate_noise (docs/calibration.md): bag " << opt.bag_path << ", parameters "
    << (opt.params_path.empty() ? "(defaults)" : opt.params_path) << "\n"
    << "# " << (r.converged ? "converged" : "NOT converged") << " after " << r.runs.size() - 1
    << " run(s); standard deviations scaled by:";
  for (int t = 0; t < kNoiseTerms; ++t)
    if (r.calibrated[t])
      y << " " << noiseTermName(static_cast<NoiseTerm>(t)) << " x" << number(r.factors[t], "%.3f")
        << ";";
  y << "\n";
  for (int t = 0; t < kNoiseTerms; ++t) {
    if (r.undetermined[t])
      y << "# " << noiseTermName(static_cast<NoiseTerm>(t))
        << ": not determined by the runs (fewer effective dof than --min-dof): unchanged\n";
    if (!r.calibrated[t]) continue;
    const std::vector<std::string> keys = keysOf(static_cast<NoiseTerm>(t), mode);
    if (keys.empty()) {
      y << "# " << noiseTermName(static_cast<NoiseTerm>(t))
        << ": the observations' own covariance (no parameter here): scale it at the source by x"
        << number(r.factors[t], "%.3f") << "\n";
    }
    for (const std::string& k : keys)
      y << k << ": " << number(r.after.at(k)) << "  # was " << number(r.before.at(k)) << "\n";
  }
  return y.str();
}

nlohmann::json toJson(const CalibrationRun& run) {
  nlohmann::json j = {{"values", run.values},
                      {"nis_scans", run.nis.scans},
                      {"nis_mean_per_dof", run.nis.mean_per_dof},
                      {"nis_share_in_95_band", run.nis.share_in_band},
                      {"nis_share_above_95_band", run.nis.share_above},
                      {"landmarks", run.landmarks}};
  if (run.gps_rmse_m >= 0.0) j["gps_rmse_m"] = run.gps_rmse_m;
  if (run.truth_pose_ate_m >= 0.0) j["truth_pose_ate_aligned_m"] = run.truth_pose_ate_m;
  if (run.truth_anees >= 0.0) j["truth_anees"] = run.truth_anees;
  const NoiseCalibrationResult& c = run.calibration;
  if (!c.ok) return j;
  j["smoother_cost_per_dof"] = c.cost_per_dof_before;
  j["calibration_iterations"] = c.iterations;
  j["calibration_converged"] = c.converged;
  for (int t = 0; t < kNoiseTerms; ++t) {
    const NoiseTermEstimate& e = c.terms[t];
    if (!e.calibrated && !e.undetermined) continue;
    j["terms"][noiseTermName(static_cast<NoiseTerm>(t))] = {{"residuals", e.residuals},
                                                            {"dof_share", e.dof_share},
                                                            {"effective_dof", e.effective_dof},
                                                            {"undetermined", e.undetermined},
                                                            {"cost_over_expected", e.ratio_before},
                                                            {"factor", e.factor}};
  }
  return j;
}

void printReport(const CalibrateNoiseResult& r, std::ostream& out) {
  const CalibrationRun& first = r.runs.front();
  const CalibrationRun& last = r.runs.back();
  out << "\nnoise term                  scalar residuals  dof share  cost/expected as given  "
         "factor (std dev)\n";
  // dof share: the expected cost per scalar residual (what the fit leaves of them).
  for (int t = 0; t < kNoiseTerms; ++t) {
    const NoiseTermEstimate& e = first.calibration.terms[t];
    if (!r.calibrated[t] && !r.undetermined[t]) continue;
    char line[200];
    std::snprintf(line, sizeof(line), "%-27s %16zu  %9.3f  %22.3f  %16s\n",
                  noiseTermName(static_cast<NoiseTerm>(t)), e.residuals, e.dof_share,
                  e.ratio_before,
                  r.undetermined[t] ? "undetermined" : number(r.factors[t], "%.3f").c_str());
    out << line;
  }
  out << "\n                                   as given   calibrated\n";
  const auto row = [&out](const char* name, double a, double b, const char* fmt = "%10.3f") {
    char line[160];
    std::snprintf(line, sizeof(line), "%-34s %s   %s\n", name, number(a, fmt).c_str(),
                  number(b, fmt).c_str());
    out << line;
  };
  row("filter NIS / dof (expected 1)", first.nis.mean_per_dof, last.nis.mean_per_dof);
  row("filter NIS in 95 % band (0.95)", first.nis.share_in_band, last.nis.share_in_band);
  row("filter NIS above the band (0.025)", first.nis.share_above, last.nis.share_above);
  row("smoother cost per dof (1)", first.calibration.cost_per_dof_before,
      last.calibration.cost_per_dof_before);
  for (int t = 0; t < kNoiseTerms; ++t) {
    if (!r.calibrated[t]) continue;
    const std::string name =
        std::string("  ") + noiseTermName(static_cast<NoiseTerm>(t)) + " cost/expected";
    row(name.c_str(), first.calibration.terms[t].ratio_before,
        last.calibration.terms[t].ratio_before);
  }
  row("landmarks", first.landmarks, last.landmarks, "%10.0f");
  if (first.gps_rmse_m >= 0.0) row("GPS RMSE [m]", first.gps_rmse_m, last.gps_rmse_m);
  if (first.truth_pose_ate_m >= 0.0)
    row("truth: pose ATE aligned [m]", first.truth_pose_ate_m, last.truth_pose_ate_m);
  if (first.truth_anees >= 0.0) row("truth: pose ANEES (3)", first.truth_anees, last.truth_anees);
}

}  // namespace

CalibrateNoiseResult calibrateNoiseOnBag(const CalibrateNoiseOptions& opt, std::ostream& log) {
  if (opt.bag_path.empty()) throw std::runtime_error("no bag given (--bag FILE)");
  if (opt.out_dir.empty()) throw std::runtime_error("no output folder given (--out DIR)");
  makeDirectory(opt.out_dir);
  CalibrateNoiseResult result;
  result.factors.fill(1.0);
  std::map<std::string, double> noise;  // run 0: the file's (and --set)
  std::string mode;
  for (int k = 0; k < opt.max_runs; ++k) {
    log << "calibrate_noise: run " << k + 1 << " (at most " << opt.max_runs << ")\n";
    CalibrationRun run = runOnce(opt, k, noise, /*calibrate=*/true, &mode, log);
    if (k == 0) result.before = run.values;
    noise = run.values;
    bool small = true;
    for (int t = 0; t < kNoiseTerms; ++t) {
      const NoiseTermEstimate& e = run.calibration.terms[t];
      result.undetermined[t] = result.undetermined[t] || e.undetermined;
      if (!e.calibrated) continue;
      result.calibrated[t] = true;
      result.factors[t] *= e.factor;
      if (std::abs(e.factor - 1.0) > opt.tolerance) small = false;
      for (const std::string& key : keysOf(static_cast<NoiseTerm>(t), mode)) noise[key] *= e.factor;
    }
    log << "  factors:";
    for (int t = 0; t < kNoiseTerms; ++t)
      if (run.calibration.terms[t].calibrated)
        log << " " << noiseTermName(static_cast<NoiseTerm>(t)) << " "
            << number(run.calibration.terms[t].factor, "%.3f");
    log << " (" << run.calibration.iterations << " smoothings)\n";
    result.runs.push_back(std::move(run));
    if (small) {
      result.converged = true;
      break;
    }
  }
  for (int t = 0; t < kNoiseTerms; ++t)
    result.undetermined[t] = result.undetermined[t] && !result.calibrated[t];
  // The check: the calibrated values as a user would run them.
  log << "calibrate_noise: check run with the calibrated values\n";
  result.runs.push_back(
      runOnce(opt, static_cast<int>(result.runs.size()), noise, true, &mode, log));
  result.after = result.runs.back().values;
  result.yaml = snippet(opt, result, mode);
  std::ofstream y(opt.out_dir + "/calibrated_noise.yaml");
  y << result.yaml;
  nlohmann::json j;
  j["converged"] = result.converged;
  for (const CalibrationRun& run : result.runs) j["runs"].push_back(toJson(run));
  for (int t = 0; t < kNoiseTerms; ++t)
    if (result.calibrated[t])
      j["factors"][noiseTermName(static_cast<NoiseTerm>(t))] = result.factors[t];
  std::ofstream(opt.out_dir + "/calibration.json") << j.dump(2) << "\n";
  if (!y) throw std::runtime_error(opt.out_dir + "/calibrated_noise.yaml: cannot write");
  return result;
}

// --- command line --------------------------------------------------------------------------------

void printCalibrateNoiseUsage(std::ostream& out) {
  out << "usage: calibrate_noise --bag FILE --params YAML --out DIR [--associator NAME]\n"
         "       [--set NAME=VALUE | --set SECTION/NAME=VALUE ...] [--runs N] [--tolerance X]\n"
         "       [--min-dof K] [--no-progress]\n"
         "Runs the bag (as ekf_slam_offline), smooths the run and estimates by what factor each\n"
         "noise term's standard deviations should be scaled: odometry translation and rotation\n"
         "(twist_sigma_v/_per_v and twist_sigma_w/_per_v, or the pose_delta alphas), range and\n"
         "bearing (sigma_range, sigma_bearing), and the observations' own covariance when they\n"
         "bring one. Reruns with the scaled values until a run's factors are within --tolerance\n"
         "of 1 (default 0.02) or --runs runs (default 6), then once more to check. Writes\n"
         "DIR/calibrated_noise.yaml (a snippet for the parameter file), DIR/calibration.json,\n"
         "DIR/run_K/ (each run's ekf_slam_offline outputs), and prints the before / after NIS and\n"
         "chi-square figures (docs/calibration.md).\n"
         "  --set      a parameter over the file's, e.g. --set sigma_range=1.0\n"
         "  --min-dof  a term with fewer effective degrees of freedom in a run (what the smoother\n"
         "             leaves of its residuals) is not calibrated (default 100)\n";
}

bool parseCalibrateNoiseArguments(const std::vector<std::string>& args, CalibrateNoiseOptions* o,
                                  bool* help, std::string* error) {
  CommandLine cl(args);
  std::string v;
  while (cl.next()) {
    if (cl.is("--no-progress")) {
      o->progress = false;
    } else if (cl.is("--bag")) {
      cl.value(&o->bag_path);
    } else if (cl.is("--params")) {
      cl.value(&o->params_path);
    } else if (cl.is("--out")) {
      cl.value(&o->out_dir);
    } else if (cl.is("--associator")) {
      cl.value(&o->associator);
    } else if (cl.is("--set")) {
      if (!cl.value(&v)) break;
      const std::size_t eq = v.find('=');
      if (eq == std::string::npos || eq == 0) {
        cl.fail("--set needs NAME=VALUE or SECTION/NAME=VALUE, got '" + v + "'");
        break;
      }
      const std::string name = v.substr(0, eq);
      const std::size_t slash = name.find('/');
      o->overrides.push_back(slash == std::string::npos
                                 ? OfflineOptions::Override{"", name, v.substr(eq + 1)}
                                 : OfflineOptions::Override{name.substr(0, slash),
                                                            name.substr(slash + 1),
                                                            v.substr(eq + 1)});
    } else if (cl.is("--runs") || cl.is("--tolerance") || cl.is("--min-dof")) {
      if (!cl.value(&v)) break;
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      const bool integer = cl.is("--runs");
      if (v.empty() || *end != '\0' || !std::isfinite(x) || x <= 0.0 ||
          (integer && (x != std::floor(x) || x > 1000))) {
        cl.fail(cl.flag() + " needs a positive " + (integer ? "integer" : "number") + ", got '" +
                v + "'");
        break;
      }
      if (cl.is("--runs")) o->max_runs = static_cast<int>(x);
      if (cl.is("--tolerance")) o->tolerance = x;
      if (cl.is("--min-dof")) o->min_dof = x;
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
  return true;
}

int calibrateNoiseMain(int argc, char** argv) {
  CalibrateNoiseOptions options;
  bool help = false;
  std::string error;
  if (!parseCalibrateNoiseArguments(std::vector<std::string>(argv + 1, argv + argc), &options,
                                    &help, &error)) {
    std::cerr << "calibrate_noise: " << error << "\n";
    printCalibrateNoiseUsage(std::cerr);
    return 2;
  }
  if (help) {
    printCalibrateNoiseUsage(std::cout);
    return 0;
  }
  try {
    const CalibrateNoiseResult r = calibrateNoiseOnBag(options, std::cerr);
    printReport(r, std::cout);
    std::cout << "\n"
              << r.yaml << "wrote " << options.out_dir
              << "/calibrated_noise.yaml, calibration.json, run_*/\n";
  } catch (const std::exception& e) {
    std::cerr << "calibrate_noise: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace ekf_slam
