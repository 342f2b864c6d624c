#include "ekf_slam/tools/evaluate.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "ekf_slam/app/command_line.h"
#include "ekf_slam/app/output_files.h"
#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {
namespace {

using Clock = std::chrono::steady_clock;

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

// The package's plugins, and "truth" / "truth_delayed": the true associations
// (KnownAssociation), not plugins.
class EvaluationPlugins : public PluginlibFactory {
 public:
  std::shared_ptr<DataAssociation> associator(const std::string& lookup) const override {
    if (lookup == kTruthLookup) return std::make_shared<KnownAssociation>();
    if (lookup == kTruthDelayedLookup)
      return std::make_shared<KnownAssociation>(truthDelayedSightings(), "truth_delayed");
    return PluginlibFactory::associator(lookup);
  }
  /// The sightings truth_delayed waits for: DJNN's admission wait (admit_evidence's default).
  static int truthDelayedSightings() { return DjnnPaperParams{}.admit_evidence; }
  static constexpr const char* kTruthLookup = "ekf_slam/truth";
  static constexpr const char* kTruthDelayedLookup = "ekf_slam/truth_delayed";
};

// --- statistics ----------------------------------------------------------------------------------

struct Spread {
  double mean = 0.0, sd = 0.0;
  std::size_t n = 0;
};

// Mean and sample standard deviation of the finite values.
Spread spread(const std::vector<double>& v) {
  Spread s;
  for (const double x : v) {
    if (!std::isfinite(x)) continue;
    s.mean += x;
    ++s.n;
  }
  if (s.n == 0) {
    s.mean = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.mean /= static_cast<double>(s.n);
  double ss = 0.0;
  for (const double x : v) {
    if (std::isfinite(x)) ss += (x - s.mean) * (x - s.mean);
  }
  s.sd = s.n > 1 ? std::sqrt(ss / static_cast<double>(s.n - 1)) : 0.0;
  return s;
}

std::string format(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string format(const Spread& s, int decimals) {
  if (s.n == 0) return "n/a";
  return format(s.mean, decimals) + " ± " + format(s.sd, decimals);
}

// Scans whose NEES is left out of the Monte Carlo average (the first second, see RunScorer).
std::size_t neesSkipScans(const sim::World& w) {
  return static_cast<std::size_t>(std::ceil(1.0 / w.observation_period - 1e-9));
}

MonteCarloNees monteCarloNees(const std::vector<const EvaluationRow*>& rows, std::size_t skip) {
  MonteCarloNees mc;
  for (const EvaluationRow* r : rows) {
    for (std::size_t k = skip; k < r->nees.size(); ++k) mc.add(k, r->nees[k]);
  }
  return mc;
}

double meanOver(const MonteCarloNees& mc) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < mc.scans(); ++k) {
    const double a = mc.average(k);
    if (std::isfinite(a)) {
      sum += a;
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}

// The final correction estimates over the runs (mean ± sd of the estimates, mean of their
// reported std devs) and how many runs end within 2 reported std devs of the world's truth.
std::string correctionSummary(const std::vector<const EvaluationRow*>& rows, const sim::World& w) {
  if (rows.empty() || rows.front()->metrics.correction_names.empty()) return "none";
  const std::vector<std::string>& names = rows.front()->metrics.correction_names;
  const std::string mode = rows.front()->odometry_correction;
  const Eigen::Vector2d truth = sim::trueCorrection(w, mode);
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    std::vector<double> est, sd;
    int within = 0;
    for (const EvaluationRow* r : rows) {
      est.push_back(r->metrics.correction(i));
      sd.push_back(r->metrics.correction_sigma(i));
      within +=
          std::abs(r->metrics.correction(i) - truth(i)) <= 2.0 * r->metrics.correction_sigma(i);
    }
    out += (i ? "; " : "") + names[i] + " " + format(spread(est), 4) + " (sd " +
           format(spread(sd).mean, 4) + ")";
    if (std::isfinite(truth(i))) {
      out += ", truth " + format(truth(i), 4) + ": " + std::to_string(within) + "/" +
             std::to_string(rows.size());
    }
  }
  return out;
}

// Rows of one world and associator, in run order.
std::vector<const EvaluationRow*> select(const Evaluation& e, const std::string& world,
                                         const std::string& associator) {
  std::vector<const EvaluationRow*> out;
  for (const EvaluationRow& r : e.rows) {
    if (r.world == world && r.associator == associator) out.push_back(&r);
  }
  return out;
}

std::vector<std::string> associatorShortNames(const EvaluateOptions& o) {
  std::vector<std::string> out;
  for (const std::string& a : o.associators) out.push_back(pluginShortName(a));
  return out;
}

// Recovery with the relocaliser: runs whose pose error came back under 1 m within 2 s of the
// kidnap, wrong relocalisations, the time it took, the error after; then the same two counts
// against the filter's own map (RunScorer::mapRelativeError).
std::string recoveryTable(const Evaluation& e, const std::string& world,
                          const std::vector<std::string>& shorts) {
  std::ostringstream md;
  md << "\nRecovery (within 2 s: pose error under " << kRecoveredDistance
     << " m at most 2 s after the kidnap; \"map\": the pose after the rigid transform that best "
        "fits the map's landmarks onto the truth):\n\n"
     << "| associator | relocaliser | runs | lost events | relocalisations | wrong | recovered | "
        "within 2 s | recovery [s] | pose RMSE after [m] | wrong (map) | within 2 s (map) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& a : shorts) {
    const auto rows = select(e, world, a);
    if (rows.empty() || rows.front()->relocaliser.empty()) continue;
    std::uint64_t lost = 0, relocs = 0, wrong = 0, recovered = 0, fast = 0, wrong_map = 0,
                  fast_map = 0;
    std::vector<double> secs, after;
    for (const EvaluationRow* r : rows) {
      const RunMetrics& m = r->metrics;
      lost += m.lost_events;
      relocs += m.relocalisations;
      wrong += m.wrong_relocalisations;
      if (m.recovery_scans >= 0) {
        ++recovered;
        fast += m.recovery_s <= 2.0;
        secs.push_back(m.recovery_s);
      }
      after.push_back(m.pose_rmse_after_recovery_m);
      wrong_map += m.wrong_relocalisations_map;
      fast_map += m.recovery_scans_map >= 0 && m.recovery_s_map <= 2.0;
    }
    md << "| " << a << " | " << rows.front()->relocaliser << " | " << rows.size() << " | " << lost
       << " | " << relocs << " | " << wrong << " | " << recovered << " | " << fast << " ("
       << format(100.0 * fast / rows.size(), 0) << " %) | " << format(spread(secs), 2) << " | "
       << format(spread(after), 3) << " | " << wrong_map << " | " << fast_map << " ("
       << format(100.0 * fast_map / rows.size(), 0) << " %) |\n";
  }
  return md.str();
}

// The map and the trajectory after the best rigid alignment, and the landmark-level scores that
// withholding decisions cannot improve (docs/simulation.md, "Metrics").
std::string mapTable(const Evaluation& e, const std::string& world,
                     const std::vector<std::string>& shorts) {
  std::ostringstream md;
  md << "\nMap and trajectory (aligned = after the best rigid 2D alignment; landmark precision = "
        "final landmarks alone on a true landmark / final landmarks; recall = true landmarks seen "
     << kMinObservationsToFind
     << "+ times held by exactly one landmark; coverage = observations of mapped landmarks "
        "paired with them; sightings used = of those, the ones the filter used on the right "
        "landmark: paired, creating it, or applied when it was created):\n\n"
     << "| associator | ATE aligned [m] | heading aligned [rad] | map RMSE aligned [m] | created | "
        "created / true seen | landmark precision | landmark recall | pairing coverage | "
        "sightings used |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& a : shorts) {
    const auto rows = select(e, world, a);
    if (rows.empty()) continue;
    std::vector<double> ate, yaw, map, created, per_true, prec, rec, cov, used;
    for (const EvaluationRow* r : rows) {
      const RunMetrics& m = r->metrics;
      ate.push_back(m.pose_ate_aligned_m);
      yaw.push_back(m.heading_rmse_aligned_rad);
      map.push_back(m.map_rmse_aligned_m);
      created.push_back(static_cast<double>(m.map.landmarks_created));
      per_true.push_back(m.map.true_landmarks_seen > 0
                             ? static_cast<double>(m.map.landmarks_created) /
                                   static_cast<double>(m.map.true_landmarks_seen)
                             : std::numeric_limits<double>::quiet_NaN());
      prec.push_back(m.map.landmark_precision);
      rec.push_back(m.map.landmark_recall);
      cov.push_back(m.map.pairing_coverage);
      used.push_back(m.map.sightings_used);
    }
    md << "| " << a << " | " << format(spread(ate), 3) << " | " << format(spread(yaw), 4) << " | "
       << format(spread(map), 3) << " | " << format(spread(created), 1) << " | "
       << format(spread(per_true), 2) << " | " << format(spread(prec), 4) << " | "
       << format(spread(rec), 4) << " | " << format(spread(cov), 4) << " | "
       << format(spread(used), 4) << " |\n";
  }
  return md.str();
}

}  // namespace

// -------------------------------------------------------------------------------------------------

std::vector<std::string> expandWorldNames(const std::vector<std::string>& patterns) {
  return sim::expandWorldNames(patterns);
}

YamlConfiguration evaluationConfiguration(const EvaluateOptions& o, const sim::World& w,
                                          const std::string& associator) {
  YamlConfiguration c(o.params_path);
  // The world's values where the file is silent.
  for (const auto& [name, value] : sim::pipelineParametersFor(w)) c.setDefault("", name, value);
  const sim::ExtractorSetup extractor = sim::extractorFor(w);
  if (!extractor.name.empty()) {
    c.setDefault("", "extractor", extractor.name);
    for (const auto& [name, value] : extractor.parameters)
      c.setDefault(extractor.name, name, value);
  }
  // The options over the file: first the top level, which decides the plugins.
  c.setOverride("", "associator", associator);
  if (o.relocaliser) c.setOverride("", "relocaliser", *o.relocaliser);
  if (!o.odometry_correction.empty())
    c.setOverride("", "odometry_correction", o.odometry_correction);
  for (const auto& [name, value] : o.overrides) {
    if (name.find('/') == std::string::npos) c.setOverride("", name, value);
  }
  // The plugins' sections: the world's values, then --set SECTION/NAME ('*': the associator).
  const std::string assoc_section = pluginShortName(associator);
  std::vector<std::string> plugins = {assoc_section};
  const std::string relocaliser = relocaliserName(c);
  if (!relocaliser.empty() && pluginShortName(relocaliser) != assoc_section)
    plugins.push_back(pluginShortName(relocaliser));
  for (const std::string& plugin : plugins) {
    for (const auto& [name, value] : sim::associatorParametersFor(w, plugin, o.knowledge))
      c.setDefault(plugin, name, value);
  }
  for (const auto& [name, value] : o.overrides) {
    const auto slash = name.find('/');
    if (slash == std::string::npos) continue;
    const std::string section = name.substr(0, slash);
    for (const std::string& plugin : plugins) {
      if ((section == "*" && plugin == assoc_section) || section == plugin)
        c.setOverride(plugin, name.substr(slash + 1), value);
    }
  }
  return c;
}

RunMetrics evaluateRun(const PipelineParts& parts, const sim::World& world, std::uint64_t seed,
                       std::vector<double>* nees_per_scan,
                       std::vector<Eigen::Vector2d>* errors_per_scan, const ScanObserver& on_scan) {
  const auto t0 = Clock::now();
  const std::unique_ptr<SlamPipeline> pipeline = makePipeline(parts);
  pipeline->setSensorOffset(world.sensor.offset);
  RunMetrics m = runSimulationOn(pipeline.get(), world, seed,
                                 dynamic_cast<KnownAssociation*>(parts.associator.get()),
                                 nees_per_scan, errors_per_scan, on_scan);
  m.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return m;
}

Evaluation runEvaluation(const EvaluateOptions& o, std::ostream& log) {
  if (o.runs < 1) throw std::invalid_argument("--runs must be at least 1");
  if (o.associators.empty()) throw std::invalid_argument("no associators given");
  Evaluation e;
  e.options = o;
  e.worlds = expandWorldNames(o.worlds);
  if (e.worlds.empty()) throw std::invalid_argument("no world given (--world NAME)");

  // Everything that can be wrong with names and parameters fails here, before any run: one
  // configuration per world and associator, built once.
  const EvaluationPlugins plugins;
  const std::vector<std::string> shorts = associatorShortNames(o);
  struct RunSetup {
    sim::World world;
    YamlConfiguration configuration;
    std::string odometry_correction;
    std::string relocaliser;
  };
  std::vector<RunSetup> setups;  // world-major, then associator
  for (const std::string& name : e.worlds) {
    const sim::World w = sim::makeWorld(name);
    for (const std::string& associator : o.associators) {
      RunSetup s{w, evaluationConfiguration(o, w, associator), "", ""};
      const PipelineParts parts = buildPipeline(s.configuration, plugins);
      s.odometry_correction = parts.config.correction.mode;
      if (parts.relocaliser) s.relocaliser = pluginShortName(parts.relocaliser_name);
      setups.push_back(std::move(s));
    }
  }

  for (std::size_t s = 0; s < setups.size(); ++s) {
    const std::uint64_t first = o.first_seed_set ? o.first_seed : setups[s].world.default_seed;
    for (int r = 0; r < o.runs; ++r) {
      EvaluationRow row;
      row.world = setups[s].world.name;
      row.associator = shorts[s % shorts.size()];
      row.run = r;
      row.seed = first + static_cast<std::uint64_t>(r);
      row.odometry_correction = setups[s].odometry_correction;
      row.relocaliser = setups[s].relocaliser;
      e.rows.push_back(std::move(row));
    }
  }

  // Runs are independent: a pool of threads takes them in order. The plugin loader is shared,
  // so creating an associator is serialised; running one is not.
  unsigned jobs = o.jobs > 0 ? static_cast<unsigned>(o.jobs) : std::thread::hardware_concurrency();
  jobs = std::max(1u, std::min<unsigned>(jobs, static_cast<unsigned>(e.rows.size())));
  std::atomic<std::size_t> next{0}, done{0};
  std::mutex mutex;
  std::string error;
  const bool progress = o.progress;
  const std::size_t runs_per_setup = static_cast<std::size_t>(o.runs);
  const auto t0 = Clock::now();
  const auto worker = [&]() {
    for (std::size_t i = next++; i < e.rows.size(); i = next++) {
      EvaluationRow& row = e.rows[i];
      const RunSetup& setup = setups[i / runs_per_setup];
      try {
        PipelineParts parts;
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (!error.empty()) return;
          parts = buildPipeline(setup.configuration, plugins);
        }
        row.metrics = evaluateRun(parts, setup.world, row.seed, &row.nees, &row.errors);
      } catch (const std::exception& ex) {
        std::lock_guard<std::mutex> lock(mutex);
        if (error.empty()) {
          error = row.world + " / " + row.associator + " / seed " + std::to_string(row.seed) +
                  ": " + ex.what();
        }
        return;
      }
      const std::size_t d = ++done;
      if (progress) {
        std::lock_guard<std::mutex> lock(mutex);
        log << "\r" << d << "/" << e.rows.size() << " runs (" << row.world << ", " << row.associator
            << ", seed " << row.seed << ")          " << std::flush;
      }
    }
  };
  std::vector<std::thread> threads;
  for (unsigned j = 0; j < jobs; ++j) threads.emplace_back(worker);
  for (std::thread& t : threads) t.join();
  if (progress) log << "\n";
  if (!error.empty()) throw std::runtime_error(error);
  e.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return e;
}

// --- output --------------------------------------------------------------------------------------

std::string summaryMarkdown(const Evaluation& e, const std::string& command) {
  std::ostringstream md;
  const EvaluateOptions& o = e.options;
  md << "# Evaluation: " << o.runs << " runs per world and associator\n\n";
  md << "    " << command << "\n\n";
  md << "Wall time " << format(e.wall_time_s, 1) << " s. Mean ± sample standard deviation over "
     << "the runs; accuracy, precision, recall, F1 per observation (ALGORITHMS.md section 9); "
     << "spurious = final-map landmarks whose majority truth is a mover or clutter, plus "
     << "duplicates of a true landmark; ANEES = Monte Carlo average NEES of the pose per scan, "
     << "averaged over the scans (first second left out), with the share of scans inside the 95 "
     << "% band for that many runs.\n";
  const std::vector<std::string> shorts = associatorShortNames(o);
  for (const std::string& world : e.worlds) {
    const sim::World w = sim::makeWorld(world);
    std::uint64_t lo = std::numeric_limits<std::uint64_t>::max(), hi = 0;
    for (const EvaluationRow& r : e.rows) {
      if (r.world != world) continue;
      lo = std::min(lo, r.seed);
      hi = std::max(hi, r.seed);
    }
    const bool stop = !w.description.empty() && w.description.back() == '.';
    md << "\n## " << world << "\n\n"
       << w.description << (stop ? " " : ". ") << "Seeds " << lo << ".." << hi << ".\n\n";
    md << "| associator | accuracy | precision | recall | F1 | landmarks | spurious | spurious % | "
          "true seen | pose RMSE [m] | ANEES | in band | association [us/scan] | run [s] | "
          "odometry correction (final; runs within 2 sd of the truth) |\n";
    md << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& a : shorts) {
      const auto rows = select(e, world, a);
      if (rows.empty()) continue;
      std::vector<double> acc, prec, rec, f1, lm, sp, sp_pct, seen, rmse, us, wall;
      for (const EvaluationRow* r : rows) {
        const RunMetrics& m = r->metrics;
        acc.push_back(m.counts.accuracy());
        prec.push_back(m.counts.precision());
        rec.push_back(m.counts.recall());
        f1.push_back(m.counts.f1());
        lm.push_back(static_cast<double>(m.map.landmarks));
        sp.push_back(static_cast<double>(m.map.spurious));
        sp_pct.push_back(m.map.landmarks > 0 ? 100.0 * m.map.spurious / m.map.landmarks : 0.0);
        seen.push_back(static_cast<double>(m.map.true_landmarks_seen));
        rmse.push_back(m.pose_rmse_m);
        us.push_back(m.association_us_mean);
        wall.push_back(m.wall_time_s);
      }
      const MonteCarloNees mc = monteCarloNees(rows, neesSkipScans(w));
      const NeesBand band = neesBand(static_cast<int>(rows.size()));
      md << "| " << a << " | " << format(spread(acc), 4) << " | " << format(spread(prec), 4)
         << " | " << format(spread(rec), 4) << " | " << format(spread(f1), 4) << " | "
         << format(spread(lm), 1) << " | " << format(spread(sp), 1) << " | "
         << format(spread(sp_pct), 1) << " | " << format(spread(seen), 1) << " | "
         << format(spread(rmse), 3) << " | " << format(meanOver(mc), 2) << " ["
         << format(band.lower, 2) << ", " << format(band.upper, 2) << "] | "
         << format(100.0 * mc.fractionInBand(), 0) << " % | " << format(spread(us), 1) << " | "
         << format(spread(wall).mean, 2) << " | " << correctionSummary(rows, w) << " |\n";
    }
    md << mapTable(e, world, shorts);
    const bool recovery = std::any_of(e.rows.begin(), e.rows.end(), [&](const EvaluationRow& r) {
      return r.world == world && !r.relocaliser.empty();
    });
    if (recovery) md << recoveryTable(e, world, shorts);
  }
  return md.str();
}

void writeEvaluation(const Evaluation& e, const std::string& command) {
  const std::string& dir = e.options.out_dir;
  makeDirectory(dir);
  {
    std::ofstream csv = openOutput(dir + "/results.csv");
    csv << "world,associator,run,seed,accuracy,precision,recall,f1,tp,fp,fn,tn,landmarks,"
           "true_landmarks_seen,true_landmarks_mapped,spurious_landmarks,non_landmarks,"
           "duplicates,pose_rmse_m,heading_rmse_rad,anees,association_us_mean,update_us_mean,"
           "scans,observations,rejected_updates,identity_switches,wall_time_s,"
           "odometry_correction,correction_1_name,correction_1,correction_1_sd,correction_1_true,"
           "correction_2_name,correction_2,correction_2_sd,correction_2_true,lost_events,"
           "relocalisations,wrong_relocalisations,recovery_scans,recovery_s,"
           "pose_rmse_after_recovery_m,error_before_kidnap_m,error_after_kidnap_m,"
           "pose_ate_aligned_m,heading_rmse_aligned_rad,"
           "map_rmse_aligned_m,landmarks_created,true_landmarks_findable,true_landmarks_found,"
           "landmark_precision,landmark_recall,pairing_coverage,recovery_scans_map,"
           "recovery_s_map,error_before_kidnap_map_m,error_after_kidnap_map_m,"
           "wrong_relocalisations_map,sightings_used\n";
    for (const EvaluationRow& r : e.rows) {
      const RunMetrics& m = r.metrics;
      csv << r.world << ',' << r.associator << ',' << r.run << ',' << r.seed << ','
          << m.counts.accuracy() << ',' << m.counts.precision() << ',' << m.counts.recall() << ','
          << m.counts.f1() << ',' << m.counts.tp << ',' << m.counts.fp << ',' << m.counts.fn << ','
          << m.counts.tn << ',' << m.map.landmarks << ',' << m.map.true_landmarks_seen << ','
          << m.map.true_landmarks_mapped << ',' << m.map.spurious << ',' << m.map.non_landmarks
          << ',' << m.map.duplicates << ',' << m.pose_rmse_m << ',' << m.heading_rmse_rad << ','
          << m.anees << ',' << m.association_us_mean << ',' << m.update_us_mean << ',' << m.scans
          << ',' << m.observations << ',' << m.rejected_updates << ',' << m.identity_switches << ','
          << m.wall_time_s << ',' << r.odometry_correction;
      // The final correction estimates, std devs and the world's true values (empty when the
      // mode has fewer states or the world no exact counterpart).
      const Eigen::Vector2d truth =
          sim::trueCorrection(sim::makeWorld(r.world), r.odometry_correction);
      for (std::size_t i = 0; i < 2; ++i) {
        if (i < m.correction_names.size()) {
          csv << ',' << m.correction_names[i] << ',' << m.correction(i) << ','
              << m.correction_sigma(i) << ',';
          if (std::isfinite(truth(i))) csv << truth(i);
        } else {
          csv << ",,,,";
        }
      }
      csv << ',' << m.lost_events << ',' << m.relocalisations << ',' << m.wrong_relocalisations
          << ',';
      // Empty when the pose never came back (or there was no kidnap).
      if (m.recovery_scans >= 0) csv << m.recovery_scans;
      csv << ',';
      if (std::isfinite(m.recovery_s)) csv << m.recovery_s;
      csv << ',';
      if (std::isfinite(m.pose_rmse_after_recovery_m)) csv << m.pose_rmse_after_recovery_m;
      for (const double error : {m.error_before_kidnap_m, m.error_after_kidnap_m}) {
        csv << ',';
        if (std::isfinite(error)) csv << error;
      }
      csv << ',' << m.pose_ate_aligned_m << ',' << m.heading_rmse_aligned_rad << ','
          << m.map_rmse_aligned_m << ',' << m.map.landmarks_created << ','
          << m.map.true_landmarks_findable << ',' << m.map.true_landmarks_found << ','
          << m.map.landmark_precision << ',' << m.map.landmark_recall << ','
          << m.map.pairing_coverage;
      // Recovery against the filter's own map (RunScorer::mapRelativeError); empty as above.
      csv << ',';
      if (m.recovery_scans_map >= 0) csv << m.recovery_scans_map;
      for (const double v :
           {m.recovery_s_map, m.error_before_kidnap_map_m, m.error_after_kidnap_map_m}) {
        csv << ',';
        if (std::isfinite(v)) csv << v;
      }
      csv << ',' << m.wrong_relocalisations_map << ',' << m.map.sightings_used;
      csv << '\n';
    }
  }
  {
    std::ofstream csv = openOutput(dir + "/nees.csv");
    csv << "world,associator,scan,anees,runs,band_lower,band_upper,position_rmse_m,"
           "heading_rmse_rad\n";
    for (const std::string& world : e.worlds) {
      const sim::World w = sim::makeWorld(world);
      for (const std::string& a : associatorShortNames(e.options)) {
        const std::vector<const EvaluationRow*> rows = select(e, world, a);
        const MonteCarloNees mc = monteCarloNees(rows, neesSkipScans(w));
        for (std::size_t k = 0; k < mc.scans(); ++k) {
          if (mc.runs(k) == 0) continue;
          const NeesBand b = neesBand(mc.runs(k));
          // Monte Carlo RMSE of the position and heading at this scan, over the runs.
          Eigen::Vector2d sum2 = Eigen::Vector2d::Zero();
          int n = 0;
          for (const EvaluationRow* r : rows) {
            if (k >= r->errors.size() || !r->errors[k].allFinite()) continue;
            sum2 += r->errors[k].cwiseAbs2();
            ++n;
          }
          const Eigen::Vector2d rmse = (sum2 / std::max(n, 1)).cwiseSqrt();
          csv << world << ',' << a << ',' << k << ',' << mc.average(k) << ',' << mc.runs(k) << ','
              << b.lower << ',' << b.upper << ',' << rmse(0) << ',' << rmse(1) << '\n';
        }
      }
    }
  }
  openOutput(dir + "/summary.md") << summaryMarkdown(e, command);
}

// --- command line --------------------------------------------------------------------------------

void printEvaluateUsage(std::ostream& out) {
  out << "usage: evaluate --world NAME[,NAME...] --out DIR [--runs N] [--associators A,B,...]\n"
         "                [--seed FIRST] [--params YAML] [--set NAME=VALUE ...] [--jobs N]\n"
         "                [--odometry-correction MODE] [--relocaliser NAME] [--oracle]\n"
         "                [--no-progress]\n"
         "Runs each associator on the same simulated seeds and scores it against the truth:\n"
         "DIR/results.csv (a row per run), DIR/nees.csv, DIR/summary.md.\n"
         "  NAME       a world (simulate --list), or a prefix with '*' (e.g. 'rrw_noise_*')\n"
         "  --runs     Monte Carlo runs per world and associator (default 20)\n"
         "  --associators  plugin names (default ekf_slam/NN,ekf_slam/JCBB,ekf_slam/DJNN);\n"
         "             'truth' = the true associations (isolates the filter);\n"
         "             'truth_delayed' = the same, each landmark admitted once seen "
      << EvaluationPlugins::truthDelayedSightings()
      << " times\n"
         "             as DJNN admits it (isolates what the wait costs; the count:\n"
         "             --set truth_delayed/admit_sightings=N)\n"
         "  --seed     seed of the first run (default: the world's default seed)\n"
         "  --params   YAML, pipeline parameters at the top level and each associator's under\n"
         "             its name; overrides the world's settings\n"
         "  --set      NAME=VALUE (pipeline), DJNN/NAME=VALUE (one associator),\n"
         "             '*/NAME=VALUE' (every associator); applied last\n"
         "  --jobs     parallel runs (default: the number of cores)\n"
         "  --odometry-correction  none, speed_scale, speed_scale_yaw_bias or wheel_factors\n"
         "             (the pipeline's odometry_correction; results.csv gets the final\n"
         "             estimates, their std devs and the world's true values)\n"
         "  --relocaliser  e.g. ekf_slam/FGCBB, \"\" for none: lost-robot recovery in every run\n"
         "             (default: the YAML's, else FGCBB, RRWSC with the RRWSC associator), scored\n"
         "             in results.csv (relocalisations, wrong_relocalisations, recovery_scans, "
         "...)\n"
         "  --oracle   also configure DJNN from the simulator's truth (landmark density and\n"
         "             spacing, clutter, movers' speed, per-world switches): a comparison\n"
         "             column only. By default a world is configured from its sensor's\n"
         "             datasheet and its vehicle alone, as a user would.\n";
}

bool parseEvaluateArguments(const std::vector<std::string>& args, EvaluateOptions* o, bool* help,
                            std::string* error) {
  CommandLine cl(args);
  std::string v;
  // The value of an integer flag, at least `lo`.
  const auto number = [&](long long lo, long long* out) {
    if (!cl.value(&v)) return false;
    try {
      std::size_t used = 0;
      const long long x = std::stoll(v, &used);
      if (used != v.size() || x < lo) throw std::invalid_argument(v);
      *out = x;
      return true;
    } catch (const std::exception&) {
      return cl.fail(cl.flag() + " needs an integer >= " + std::to_string(lo) + ", got '" + v +
                     "'");
    }
  };
  long long n = 0;
  while (cl.next()) {
    if (cl.is("--no-progress")) {
      o->progress = false;
    } else if (cl.is("--oracle")) {
      o->knowledge = sim::Knowledge::kOracle;
    } else if (cl.is("--world") || cl.is("--worlds")) {
      if (cl.value(&v)) {
        for (const auto& w : splitList(v)) o->worlds.push_back(w);
      }
    } else if (cl.is("--out")) {
      cl.value(&o->out_dir);
    } else if (cl.is("--associators") || cl.is("--associator")) {
      if (cl.value(&v)) o->associators = splitList(v);
    } else if (cl.is("--params")) {
      cl.value(&o->params_path);
    } else if (cl.is("--odometry-correction")) {
      cl.value(&o->odometry_correction);
    } else if (cl.is("--relocaliser")) {
      if (cl.value(&v)) o->relocaliser = v;
    } else if (cl.is("--runs")) {
      if (number(1, &n)) o->runs = static_cast<int>(n);
    } else if (cl.is("--jobs")) {
      if (number(1, &n)) o->jobs = static_cast<int>(n);
    } else if (cl.is("--seed")) {
      if (number(0, &n)) {
        o->first_seed = static_cast<std::uint64_t>(n);
        o->first_seed_set = true;
      }
    } else if (cl.is("--set")) {
      if (!cl.value(&v)) break;
      const auto eq = v.find('=');
      if (eq == std::string::npos || eq == 0) {
        cl.fail("--set needs NAME=VALUE, got '" + v + "'");
      } else {
        o->overrides.emplace_back(v.substr(0, eq), v.substr(eq + 1));
      }
    } else {
      cl.unknown();
    }
  }
  if (!cl.finish(help, error)) return false;
  if (*help) return true;
  if (o->worlds.empty() || o->out_dir.empty()) {
    *error = "--world and --out are required";
    return false;
  }
  if (o->associators.empty()) {
    *error = "--associators needs at least one name";
    return false;
  }
  return true;
}

int evaluateMain(int argc, char** argv) {
  EvaluateOptions options;
  bool help = false;
  std::string error;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (!parseEvaluateArguments(args, &options, &help, &error)) {
    std::cerr << "evaluate: " << error << "\n";
    printEvaluateUsage(std::cerr);
    return 2;
  }
  if (help) {
    printEvaluateUsage(std::cout);
    return 0;
  }
  std::string command = "rosrun ekf_slam evaluate";
  for (const std::string& a : args) {
    const bool plain = a.find_first_of(" *'\"$") == std::string::npos;
    command += " " + (plain ? a : "'" + a + "'");
  }
  try {
    const Evaluation e = runEvaluation(options, std::cerr);
    writeEvaluation(e, command);
    std::cout << summaryMarkdown(e, command);
    std::cout << "\nwrote " << options.out_dir << "/{results.csv,nees.csv,summary.md} ("
              << e.rows.size() << " runs in " << format(e.wall_time_s, 1) << " s)\n";
  } catch (const std::exception& ex) {
    std::cerr << "evaluate: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace ekf_slam
