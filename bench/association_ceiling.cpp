// The association ceiling of simulated worlds (docs/results.md, "The ceiling"): for every scan of
// every seed, the simulator's very scans associated with perfect knowledge of the TRUE pose and
// the TRUE landmarks (associationCeiling). Prints, per world, the share of the observations that
// the joint maximum-likelihood assignment, each observation's own maximum likelihood and the
// posterior-marginal decision give their true landmark, and the joint one by true range.
//
//   association_ceiling --worlds 'rrw_noise_*' [--runs 20] [--out FILE.csv]
//                       [--measurement-noise-of WORLD] [--max-range R] [--sweeps 200]
//                       [--associator RRWSC]
//
// --worlds: comma-separated names or prefixes ending in '*'; seeds 1..runs.
// --measurement-noise-of WORLD: the range and bearing noise of WORLD instead (e.g. rrw_noise_1:
//   the reading in which only the motion noise grows; given the true pose that noise is moot).
// --max-range R: the sensor sees only landmarks within R [m] instead of the world's range.
// The candidates of a scan are the landmarks in view of the true pose (range and field of view).
// --sweeps N: Metropolis-Hastings sweeps per scan for the marginals (0: skip them).
// --associator NAME (RRWSC, DJNN, Hungarian, NN; default parameters, as `evaluate`): the same
//   scans also go through the SlamPipeline with that associator, scored per observation by
//   AssociationScorer (TP + TN right), beside the ceiling by range bin: where it loses beyond the
//   physics.
// --out: one CSV row per world, seed and range bin (range_to inf: the seed's whole run).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/rrwsc.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/evaluation/association_ceiling.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace {

using namespace ekf_slam;

constexpr double kInf = std::numeric_limits<double>::infinity();
// True-range bins [m]: the rrw worlds see landmarks up to about 280 m away.
const std::vector<double> kEdges = {0.0, 50.0, 100.0, 150.0, 200.0, kInf};

struct Tally {
  std::uint64_t observations = 0, joint = 0, individual = 0, marginal = 0, associator = 0;
  double marginal_expected = 0.0;
  Tally& operator+=(const Tally& o) {
    observations += o.observations;
    associator += o.associator;
    joint += o.joint;
    individual += o.individual;
    marginal += o.marginal;
    marginal_expected += o.marginal_expected;
    return *this;
  }
};

struct RunTally {
  std::vector<Tally> bins = std::vector<Tally>(kEdges.size() - 1);
  Tally all;
  std::uint64_t scans = 0, scans_joint_right = 0, skipped = 0;
  // The associator's pairings with a younger duplicate of the right landmark (scored wrong).
  std::uint64_t duplicate_pairings = 0;
  std::vector<double> wrong_gaps;  // distance from the true landmark to the joint choice [m]
};

struct Options {
  std::vector<std::string> worlds;
  int runs = 20;
  std::string out;
  std::string noise_of;
  double max_range = std::numeric_limits<double>::quiet_NaN();
  std::string associator;
  CeilingOptions ceiling;
};

std::shared_ptr<DataAssociation> makeAssociator(const std::string& name) {
  if (name == "RRWSC") return std::make_shared<RRWSC>();
  if (name == "DJNN") return std::make_shared<DJNN>();
  if (name == "Hungarian") return std::make_shared<Hungarian>();
  if (name == "NN") return std::make_shared<NN>();
  throw std::invalid_argument("unknown associator '" + name + "' (RRWSC, DJNN, Hungarian, NN)");
}

void usage() {
  std::fprintf(stderr,
               "usage: association_ceiling --worlds 'rrw_noise_*' [--runs 20] [--out FILE.csv]\n"
               "         [--measurement-noise-of WORLD] [--max-range R] [--sweeps 200]\n"
               "         [--associator RRWSC|DJNN|Hungarian|NN]\n");
}

Options parse(int argc, char** argv) {
  Options o;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (a + 1 >= argc) throw std::invalid_argument("missing value after " + arg);
    const std::string value = argv[++a];
    if (arg == "--worlds") {
      std::stringstream list(value);
      for (std::string w; std::getline(list, w, ',');) o.worlds.push_back(w);
    } else if (arg == "--runs") {
      o.runs = std::stoi(value);
    } else if (arg == "--out") {
      o.out = value;
    } else if (arg == "--measurement-noise-of") {
      o.noise_of = value;
    } else if (arg == "--max-range") {
      o.max_range = std::stod(value);
    } else if (arg == "--associator") {
      makeAssociator(value);  // fails here on an unknown name, before any run
      o.associator = value;
    } else if (arg == "--sweeps") {
      o.ceiling.sweeps = std::stoi(value);
    } else {
      throw std::invalid_argument("unknown option " + arg);
    }
  }
  if (o.worlds.empty()) throw std::invalid_argument("--worlds is required");
  if (o.runs < 1) throw std::invalid_argument("--runs must be at least 1");
  if (!(std::isnan(o.max_range) || o.max_range > 0.0)) {
    throw std::invalid_argument("--max-range must be > 0");
  }
  return o;
}

// Adds one observation set's ceiling to `t`; `right` (may be null): whether the associator under
// test got each of the set's observations right.
void addSet(const sim::World& world, const sim::ObservationSet& set, const CeilingOptions& options,
            const std::vector<char>* right, sim::Random* rng, RunTally* t) {
  const RangeBearingModel model(world.sensor.offset);
  std::vector<Observation> obs;
  std::vector<int> truth, index;
  for (std::size_t k = 0; k < set.observations.size(); ++k) {
    const sim::SimObservation& o = set.observations[k];
    if (!sim::isStaticLandmark(o.truth_id)) {
      ++t->skipped;  // movers and clutter have no landmark to be right about
      continue;
    }
    obs.push_back({o.z, o.R, o.kind});
    truth.push_back(static_cast<int>(o.truth_id));
    index.push_back(static_cast<int>(k));
  }
  // Only a landmark in view of the true pose can have made a return, which the perfect-knowledge
  // observer knows (in the whole-map worlds every landmark is in view).
  const sim::SensorSpec& sensor = world.sensor;
  std::vector<Eigen::Vector2d> candidates;
  std::vector<int> landmark_of;  // candidate -> landmark index
  for (std::size_t j = 0; j < world.landmarks.size(); ++j) {
    const Eigen::Vector2d z = model.predict(set.true_pose, world.landmarks[j]);
    if (z(0) >= sensor.min_range && z(0) <= sensor.max_range &&
        (sensor.field_of_view >= 2.0 * M_PI || std::abs(z(1)) <= 0.5 * sensor.field_of_view)) {
      candidates.push_back(world.landmarks[j]);
      landmark_of.push_back(static_cast<int>(j));
    }
  }
  ScanCeiling c = associationCeiling(model, set.true_pose, candidates, obs, options, rng);
  for (std::vector<int>* d : {&c.joint, &c.individual, &c.marginal}) {
    for (int& j : *d) j = landmark_of[j];
  }
  ++t->scans;
  bool all_right = true;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const double r = model.predict(set.true_pose, world.landmarks[truth[i]])(0);
    const std::size_t bin = std::upper_bound(kEdges.begin(), kEdges.end(), r) - kEdges.begin() - 1;
    Tally one;
    one.observations = 1;
    one.joint = c.joint[i] == truth[i];
    one.individual = c.individual[i] == truth[i];
    if (!c.marginal.empty()) {
      one.marginal = c.marginal[i] == truth[i];
      one.marginal_expected = c.marginal_probability[i];
    }
    if (right != nullptr) one.associator = (*right)[index[i]];
    t->bins[std::min(bin, t->bins.size() - 1)] += one;
    t->all += one;
    if (!one.joint) {
      all_right = false;
      t->wrong_gaps.push_back((world.landmarks[c.joint[i]] - world.landmarks[truth[i]]).norm());
    }
  }
  t->scans_joint_right += all_right;
}

RunTally runSeed(const sim::World& world, std::uint64_t seed, const Options& o) {
  RunTally t;
  sim::Random rng(sim::Random::streamSeed(seed, 0xce11));
  sim::Simulation s(world, seed);
  if (o.associator.empty()) {
    for (auto e = s.next(); e != sim::Simulation::Event::kEnd; e = s.next()) {
      if (e == sim::Simulation::Event::kObservations) {
        addSet(world, s.observations(), o.ceiling, nullptr, &rng, &t);
      }
    }
    return t;
  }
  // The associator as `evaluate` runs it (runSimulation), each observation scored on its own.
  std::shared_ptr<DataAssociation> associator = makeAssociator(o.associator);
  associator->configure(MapParameterSource(sim::associatorParametersFor(world, o.associator)));
  SlamPipeline pipeline(sim::pipelineConfigFor(world), associator);
  pipeline.setSensorOffset(world.sensor.offset);
  AssociationScorer scorer;
  std::vector<LandmarkId> truth;
  std::vector<Outcome> outcomes;
  std::vector<char> right;
  feedSimulation(s, pipeline, [&](const sim::ObservationSet& set) {
    const ScanReport report =
        pipeline.processObservations(set.stamp + sim::kStampOffset, set.toObservations());
    const std::vector<LandmarkId> all = set.truthIds();
    truth.clear();
    for (const std::uint32_t i : report.input_index) truth.push_back(all[i]);
    scorer.addScan(truth, report.association, report.removed, &outcomes);
    right.assign(all.size(), 0);
    for (std::size_t k = 0; k < outcomes.size(); ++k) {
      right[report.input_index[k]] =
          outcomes[k] == Outcome::kTruePositive || outcomes[k] == Outcome::kTrueNegative;
    }
    addSet(world, set, o.ceiling, &right, &rng, &t);
    return true;
  });
  t.duplicate_pairings = scorer.duplicatePairings();
  return t;
}

double share(std::uint64_t k, std::uint64_t n) { return n == 0 ? NAN : double(k) / double(n); }

std::string range(std::size_t b) {
  char buf[48];
  if (std::isinf(kEdges[b + 1])) {
    std::snprintf(buf, sizeof(buf), ">= %.0f m", kEdges[b]);
  } else {
    std::snprintf(buf, sizeof(buf), "%.0f-%.0f m", kEdges[b], kEdges[b + 1]);
  }
  return buf;
}

void csvRow(std::ofstream& csv, const std::string& world, std::uint64_t seed, double from,
            double to, const Tally& t, const RunTally& run) {
  csv << world << ',' << seed << ',' << from << ',' << to << ',' << t.observations << ',' << t.joint
      << ',' << t.individual << ',' << t.marginal << ',' << t.marginal_expected << ',' << run.scans
      << ',' << run.scans_joint_right << '\n';
}

int run(const Options& o) {
  std::ofstream csv;
  if (!o.out.empty()) {
    csv.open(o.out);
    if (!csv) throw std::runtime_error("cannot write " + o.out);
    csv << "world,seed,range_from,range_to,observations,joint_correct,individual_correct,"
           "marginal_correct,marginal_expected,associator_correct,scans,scans_joint_all_correct\n";
  }
  std::vector<std::string> names = sim::expandWorldNames(o.worlds);
  std::vector<RunTally> totals;
  for (const std::string& name : names) {
    sim::World world = sim::makeWorld(name);
    if (!o.noise_of.empty()) {
      const sim::NoiseSpec n = sim::makeWorld(o.noise_of).noise;
      world.noise.sigma_range = n.sigma_range;
      world.noise.sigma_bearing = n.sigma_bearing;
    }
    if (!std::isnan(o.max_range)) world.sensor.max_range = o.max_range;
    RunTally total;
    for (int seed = 1; seed <= o.runs; ++seed) {
      RunTally t = runSeed(world, seed, o);
      if (csv.is_open()) {
        for (std::size_t b = 0; b < t.bins.size(); ++b) {
          csvRow(csv, name, seed, kEdges[b], kEdges[b + 1], t.bins[b], t);
        }
        csvRow(csv, name, seed, 0.0, kInf, t.all, t);
      }
      for (std::size_t b = 0; b < t.bins.size(); ++b) total.bins[b] += t.bins[b];
      total.all += t.all;
      total.scans += t.scans;
      total.scans_joint_right += t.scans_joint_right;
      total.skipped += t.skipped;
      total.duplicate_pairings += t.duplicate_pairings;
      total.wrong_gaps.insert(total.wrong_gaps.end(), t.wrong_gaps.begin(), t.wrong_gaps.end());
    }
    totals.push_back(std::move(total));
  }

  const bool with = !o.associator.empty();
  std::printf(
      "| world | observations | joint ML | per-observation ML | posterior marginal (expected) | "
      "scans all right (joint ML) | wrong (joint ML): median gap to the true landmark [m] |%s\n"
      "|---|---|---|---|---|---|---|%s\n",
      with ? (" " + o.associator + " (TP + TN) | its pairings with a duplicate |").c_str() : "",
      with ? "---|---|" : "");
  for (std::size_t w = 0; w < names.size(); ++w) {
    RunTally& t = totals[w];
    std::sort(t.wrong_gaps.begin(), t.wrong_gaps.end());
    const double gap = t.wrong_gaps.empty() ? NAN : t.wrong_gaps[t.wrong_gaps.size() / 2];
    char marginal[48] = "-";
    if (o.ceiling.sweeps > 0) {
      std::snprintf(marginal, sizeof(marginal), "%.4f (%.4f)",
                    share(t.all.marginal, t.all.observations),
                    t.all.marginal_expected / t.all.observations);
    }
    std::printf("| %s | %llu | %.4f | %.4f | %s | %.3f | %.1f |", names[w].c_str(),
                static_cast<unsigned long long>(t.all.observations),
                share(t.all.joint, t.all.observations), share(t.all.individual, t.all.observations),
                marginal, share(t.scans_joint_right, t.scans), gap);
    if (with) {
      std::printf(" %.4f | %.4f |", share(t.all.associator, t.all.observations),
                  share(t.duplicate_pairings, t.all.observations));
    }
    std::printf("\n");
  }
  std::printf(
      "\nJoint ML by the true range (%s; share of the observations in the bin):\n\n| world |",
      with ? ("ceiling / " + o.associator).c_str() : "ceiling");
  for (std::size_t b = 0; b < kEdges.size() - 1; ++b) std::printf(" %s |", range(b).c_str());
  std::printf("\n|---|");
  for (std::size_t b = 0; b < kEdges.size() - 1; ++b) std::printf("---|");
  std::printf("\n");
  for (std::size_t w = 0; w < names.size(); ++w) {
    const RunTally& t = totals[w];
    std::printf("| %s |", names[w].c_str());
    for (const Tally& b : t.bins) {
      std::printf(" %.4f", share(b.joint, b.observations));
      if (with) std::printf(" / %.4f", share(b.associator, b.observations));
      std::printf(" (%.2f) |", share(b.observations, t.all.observations));
    }
    std::printf("\n");
    if (t.skipped > 0) {
      std::printf("  (%s: %llu mover / clutter returns not scored)\n", names[w].c_str(),
                  static_cast<unsigned long long>(t.skipped));
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "association_ceiling: %s\n", e.what());
    usage();
    return 2;
  }
}
