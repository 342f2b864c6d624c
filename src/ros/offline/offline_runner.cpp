#include "ekf_slam/ros/offline/offline_runner.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>

#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/command_line.h"
#include "ekf_slam/app/output_files.h"
#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/core/common/stopwatch.h"
#include "ekf_slam/core/pipeline/input_sequencer.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/ros/offline/bag_input.h"
#include "ekf_slam/ros/offline/offline_report.h"
#include "ekf_slam/ros/offline/run_record.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {
namespace {

using Clock = std::chrono::steady_clock;

// Captures, on request, the association problem of one scan: associate() sees the EKF predicted
// to the scan and the final observations, which is exactly what a replay needs, without the
// pipeline exposing its internals. Every other hook goes to the associator unchanged.
class CapturingAssociator : public ForwardingAssociator {
 public:
  using ForwardingAssociator::ForwardingAssociator;

  AssociationResult associate(const AssociationContext& context) override {
    if (armed_) {
      armed_ = false;
      problem_ = makeAssociationProblem(context.ekf(), context.model(), context.observations());
    }
    return ForwardingAssociator::associate(context);
  }

  /// Captures the next associate() call.
  void arm() {
    armed_ = true;
    problem_.reset();
  }
  void disarm() { armed_ = false; }
  const std::optional<AssociationProblem>& problem() const { return problem_; }

 private:
  bool armed_ = false;
  std::optional<AssociationProblem> problem_;
};

// --- progress bar --------------------------------------------------------------------------------

class Progress {
 public:
  Progress(bool enabled, std::size_t total) : enabled_(enabled && total > 0), total_(total) {}
  void update(std::size_t done) {
    if (!enabled_) return;
    const int percent = static_cast<int>(100 * done / total_);
    if (percent == last_) return;
    last_ = percent;
    const int width = 40, filled = percent * width / 100;
    std::fprintf(stderr, "\r[%.*s%*s] %3d%% (%zu/%zu)", filled,
                 "########################################", width - filled, "", percent, done,
                 total_);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  std::size_t total_;
  int last_ = -1;
};
// CPU time of the calling thread: on a machine shared with other jobs it measures the loop's own
// work where the wall time also counts the time the other jobs held the CPU.
double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

// -------------------------------------------------------------------------------------------------

OfflineSummary runOffline(const OfflineOptions& o, std::ostream& log) {
  if (o.bag_path.empty()) throw std::runtime_error("no bag given (--bag FILE)");
  if (o.out_dir.empty()) throw std::runtime_error("no output folder given (--out DIR)");

  // Parameters: one builder for every entry point (app/pipeline_builder.h), the options over
  // the file's `associator` and `relocaliser`.
  YamlConfiguration configuration(o.params_path);
  for (const OfflineOptions::Override& v : o.overrides)
    configuration.setOverride(v.section, v.name, v.value);
  if (!o.associator.empty()) configuration.setOverride("", "associator", o.associator);
  if (o.relocaliser) configuration.setOverride("", "relocaliser", *o.relocaliser);
  PipelineParts parts = buildPipeline(configuration, PluginlibFactory());
  const PipelineConfig& config = parts.config;
  const std::string short_name = pluginShortName(parts.associator_name);
  const std::string relocaliser_short =
      parts.relocaliser_name.empty() ? "" : pluginShortName(parts.relocaliser_name);
  auto capturing = std::make_shared<CapturingAssociator>(parts.associator);
  parts.associator = capturing;
  const std::unique_ptr<SlamPipeline> owned_pipeline = makePipeline(parts);
  SlamPipeline& pipeline = *owned_pipeline;
  pipeline.recordUpdateShapes(true);  // update_shapes.csv

  if (o.unknown_pose && o.load_map.empty())
    throw std::runtime_error("--unknown-pose needs --load-map FILE");
  if (o.unknown_pose && !parts.relocaliser)
    throw std::runtime_error("--unknown-pose needs a relocaliser (it is off: --relocaliser NAME)");
  if (o.smooth && !o.load_map.empty())
    throw std::runtime_error(
        "--smooth cannot be used with --load-map (the smoother has no prior "
        "for the loaded landmarks)");
  if (!o.load_map.empty()) pipeline.loadMap(o.load_map, /*reset_pose=*/true, o.unknown_pose);

  makeDirectory(o.out_dir);

  // Bag reading is timed apart from the processing.
  const auto t_read = Clock::now();
  const BagContents bag = readBag(o);
  const double bag_read_s = secondsSince(t_read);

  SensorFrames frames(bag, o, log);
  std::optional<Eigen::Vector3d> offset;  // of the first sensor message used (metrics.json)
  const std::string* current_frame = nullptr;
  RunRecord record(o, bag, log);
  bool dumped = false;
  // One processed scan: its record, the caller's look, the problem dump.
  const auto recordScan = [&](const ScanReport& r, const ObservationsInput* input) {
    record.add(r, pipeline, input);
    if (!r.association.notice.empty()) log << "warning: " << r.association.notice << "\n";
    if (o.on_scan) o.on_scan(r, pipeline);
    if (o.dump_problem_scan && r.scan == *o.dump_problem_scan) {
      capturing->disarm();
      // No associate() call (no observations): the state is the pre-association one anyway.
      const AssociationProblem problem =
          capturing->problem()
              ? *capturing->problem()
              : makeAssociationProblem(pipeline.ekf(), pipeline.observationModel(), r.observations);
      writeAssociationProblem(
          problem, o.out_dir + "/problem_" + std::to_string(*o.dump_problem_scan) + ".json");
      dumped = true;
    }
  };

  // The sequencer puts the inputs in stamp order exactly as in the node; they are handed to it
  // in bag order, as a live node would receive them.
  InputSequencer<InputRef> sequencer(
      InputSequencerConfig{config.max_latency, config.time_jump_threshold});
  std::uint64_t time_jumps = 0;
  InputSequencer<InputRef>::Item item;
  const auto drain = [&]() {
    while (sequencer.next(&item)) {
      switch (item.kind) {
        case InputSequencer<InputRef>::Kind::kOdometry:
          pipeline.addOdometry(item.odometry);
          break;
        case InputSequencer<InputRef>::Kind::kDropped:  // handled inside InputSequencer
          break;
        case InputSequencer<InputRef>::Kind::kTimeJump:
          ++time_jumps;
          log << "warning: time jumped backwards to " << std::fixed << item.stamp
              << std::defaultfloat << " s: the map is reset\n";
          pipeline.reset();
          record.restartScoring();  // landmark ids start again
          break;
        case InputSequencer<InputRef>::Kind::kScan:
          if (o.dump_problem_scan && record.scans == *o.dump_problem_scan) capturing->arm();
          for (const OfflineOptions::Kidnap& k : o.kidnaps) {
            if (k.scan != record.scans) continue;
            pipeline.injectPoseJump(k.jump);
            log << "kidnap before scan " << k.scan << ": pose jump " << k.jump.transpose() << "\n";
          }
          const std::string& frame = item.scan.observations
                                         ? bag.observation_sets[item.scan.index].frame_id
                                         : bag.scans[item.scan.index].frame_id;
          if (current_frame == nullptr || *current_frame != frame) {
            pipeline.setSensorOffset(*frames.offset(frame));  // known: checked on arrival
            current_frame = &frame;
          }
          if (item.scan.observations) {
            const ObservationsInput& s = bag.observation_sets[item.scan.index];
            recordScan(pipeline.processObservations(s.stamp, s.observations), &s);
          } else {
            const ScanInput& s = bag.scans[item.scan.index];
            const ScanReport r = pipeline.processScan(s.stamp, s.data);
            if (r.geometry_error && pipeline.counters().inconsistent_scans == 1) {
              log << "warning: scan at " << std::fixed << s.stamp << std::defaultfloat << ": "
                  << r.geometry_error << ": used for prediction only (and every such scan)\n";
            }
            if (!r.duplicate) recordScan(r, nullptr);
          }
          break;
      }
    }
  };

  Progress progress(o.progress && ::isatty(STDERR_FILENO), bag.arrivals.size());
  std::uint64_t invalid_stamps = 0, zero_stamps = 0;
  const auto t_loop = Clock::now();
  const double cpu_loop = threadCpuSeconds();
  for (std::size_t a = 0; a < bag.arrivals.size(); ++a) {
    const Arrival& in = bag.arrivals[a];
    SequencerStatus st = SequencerStatus::kQueued;
    // The node's checks on arrival: zero stamps and sensor frames without a transform skipped.
    const double stamp = in.kind == Arrival::kOdometry ? bag.odometry[in.index].stamp
                         : in.kind == Arrival::kScan   ? bag.scans[in.index].stamp
                                                       : bag.observation_sets[in.index].stamp;
    if (stamp == 0.0) {
      if (zero_stamps++ == 0)
        log << "warning: messages with a zero stamp are skipped (they would reset the map)\n";
      continue;
    }
    if (in.kind != Arrival::kOdometry) {
      const std::string& frame = in.kind == Arrival::kScan
                                     ? bag.scans[in.index].frame_id
                                     : bag.observation_sets[in.index].frame_id;
      const Eigen::Vector3d* frame_offset = frames.offset(frame);
      if (frame_offset == nullptr) continue;
      if (!offset) offset = *frame_offset;
    }
    switch (in.kind) {
      case Arrival::kOdometry:
        st = sequencer.addOdometry(bag.odometry[in.index]);
        break;
      case Arrival::kScan:
        st = sequencer.addScan(bag.scans[in.index].stamp, InputRef{false, in.index});
        break;
      case Arrival::kObservations:
        st = sequencer.addScan(bag.observation_sets[in.index].stamp, InputRef{true, in.index});
        break;
    }
    invalid_stamps += st == SequencerStatus::kInvalidStamp;
    drain();
    if ((a & 255) == 0) progress.update(a);
  }
  sequencer.flush();
  drain();
  progress.update(bag.arrivals.size());
  if (!offset) {
    throw std::runtime_error(
        o.bag_path + ": no scan or observation message could be used: " +
        (frames.missing().empty()
             ? std::string("every one has a zero stamp")
             : frames.missing() + "; the sensor pose on the vehicle is needed"));
  }
  const double wall_time_s = secondsSince(t_loop);
  const double loop_cpu_s = threadCpuSeconds() - cpu_loop;
  progress.finish();
  if (o.on_finish) o.on_finish(pipeline);

  LoopStats stats;
  stats.associator = short_name;
  stats.relocaliser = relocaliser_short;
  stats.bag_read_s = bag_read_s;
  stats.wall_time_s = wall_time_s;
  stats.loop_cpu_s = loop_cpu_s;
  stats.sensor_offset = *offset;
  stats.sequencer = sequencer.counters();
  stats.invalid_stamps = invalid_stamps;
  stats.zero_stamps = zero_stamps;
  stats.skipped_no_tf = frames.skipped();
  stats.time_jumps = time_jumps;
  stats.problem_dumped = dumped;
  return writeOfflineReport(o, bag, record, pipeline, stats, log);
}

// --- command line --------------------------------------------------------------------------------

void printOfflineUsage(std::ostream& out, const std::string& program) {
  out << "usage: " << program
      << " --bag FILE --out DIR [--params YAML] [--associator NAME] [--dump-problem SCAN]\n"
         "       [--relocaliser NAME] [--load-map FILE [--unknown-pose]]\n"
         "       [--kidnap SCAN:DX,DY,DYAW ...] [--landmark-trace] [--smooth]\n"
         "       [--no-plot] [--no-progress] [--scan-topic T] [--odom-topic T]\n"
         "       [--observations-topic T] [--gps-topic T] [--tf-static-topic T]\n"
         "       [--ground-truth-topic T] [--true-map-topic T] [--base-frame F]\n"
         "Replays a bag through the SLAM pipeline (no roscore) and writes trajectory.csv,\n"
         "landmarks.csv, associations.csv, gps.csv, metrics.json, map.txt and map.png to DIR.\n"
         "A simulated bag (observations with truth ids, /ground_truth) is also scored against\n"
         "its truth: metrics.json 'truth' (accuracy, precision, recall, F1, spurious landmarks,\n"
         "pose RMSE, ANEES).\n"
         "  YAML: pipeline parameters at the top level, each associator's under its name\n"
         "        (config/victoria_park.yaml)\n"
         "  NAME: e.g. DJNN or ekf_slam/DJNN (default: the YAML's 'associator', else "
      << AssociatorLoader::kDefault
      << ")\n"
         "  SCAN: 0-based scan whose association problem goes to DIR/problem_SCAN.json\n"
         "        (replay it with replay_association)\n"
         "  --relocaliser  e.g. FGCBB: lost-robot recovery; \"\" turns it off (default: the\n"
         "        YAML's 'relocaliser', else FGCBB, RRWSC with the RRWSC associator); its\n"
         "        parameters come from its section of the YAML\n"
         "  --load-map     a map.txt (~save_map format) to start from; --unknown-pose: the pose\n"
         "        in it is unknown, the run starts lost and relocalises globally\n"
         "  --kidnap       before 0-based scan SCAN, jump the pose estimate by DX,DY [m] (map\n"
         "        frame) and DYAW [rad] without telling the filter (repeatable)\n"
         "  --landmark-trace  every landmark's mean and covariance after every scan, to\n"
         "        DIR/landmark_trace.csv (scripts/map_drift.py)\n"
         "  --smooth       after the run, re-estimate every scan pose and landmark from all of\n"
         "        its odometry and pairings (batch smoother): DIR/trajectory_smoothed.csv,\n"
         "        DIR/map_smoothed.txt, metrics.json 'smoothing' (not with --load-map)\n";
}

bool parseOfflineArguments(const std::vector<std::string>& args, OfflineOptions* o, bool* help,
                           std::string* error) {
  CommandLine cl(args);
  std::string v;
  while (cl.next()) {
    std::string* target = cl.is("--bag")                  ? &o->bag_path
                          : cl.is("--out")                ? &o->out_dir
                          : cl.is("--params")             ? &o->params_path
                          : cl.is("--associator")         ? &o->associator
                          : cl.is("--load-map")           ? &o->load_map
                          : cl.is("--scan-topic")         ? &o->scan_topic
                          : cl.is("--odom-topic")         ? &o->odom_topic
                          : cl.is("--observations-topic") ? &o->observations_topic
                          : cl.is("--gps-topic")          ? &o->gps_topic
                          : cl.is("--tf-static-topic")    ? &o->tf_static_topic
                          : cl.is("--ground-truth-topic") ? &o->ground_truth_topic
                          : cl.is("--true-map-topic")     ? &o->true_map_topic
                          : cl.is("--base-frame")         ? &o->base_frame
                                                          : nullptr;
    if (target != nullptr) {
      cl.value(target);
    } else if (cl.is("--relocaliser")) {
      if (cl.value(&v)) o->relocaliser = v;  // "" is a value: off
    } else if (cl.is("--no-plot")) {
      o->plot = false;
    } else if (cl.is("--no-progress")) {
      o->progress = false;
    } else if (cl.is("--unknown-pose")) {
      o->unknown_pose = true;
    } else if (cl.is("--landmark-trace")) {
      o->landmark_trace = true;
    } else if (cl.is("--smooth")) {
      o->smooth = true;
    } else if (cl.is("--kidnap")) {
      if (!cl.value(&v)) break;
      OfflineOptions::Kidnap k;
      unsigned long scan = 0;
      double dx = 0, dy = 0, dyaw = 0;
      int used = 0;
      if (std::sscanf(v.c_str(), "%lu:%lf,%lf,%lf%n", &scan, &dx, &dy, &dyaw, &used) != 4 ||
          used != static_cast<int>(v.size()) || v[0] == '-' ||
          scan > std::numeric_limits<std::uint32_t>::max() ||
          !Eigen::Vector3d(dx, dy, dyaw).allFinite()) {
        cl.fail("--kidnap needs SCAN:DX,DY,DYAW (e.g. 2000:30,-20,1.5), got '" + v + "'");
        break;
      }
      k.scan = static_cast<std::uint32_t>(scan);
      k.jump = Eigen::Vector3d(dx, dy, dyaw);
      o->kidnaps.push_back(k);
    } else if (cl.is("--dump-problem")) {
      if (!cl.value(&v)) break;
      char* end = nullptr;
      errno = 0;
      const unsigned long scan = std::strtoul(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || v[0] == '-' || errno != 0 ||
          scan > std::numeric_limits<std::uint32_t>::max()) {
        cl.fail("--dump-problem needs a scan index (0, 1, ...), got '" + v + "'");
        break;
      }
      o->dump_problem_scan = static_cast<std::uint32_t>(scan);
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

int offlineMain(int argc, char** argv) {
  const std::string program = "ekf_slam_offline";
  OfflineOptions options;
  bool help = false;
  std::string error;
  if (!parseOfflineArguments(std::vector<std::string>(argv + 1, argv + argc), &options, &help,
                             &error)) {
    std::cerr << program << ": " << error << "\n";
    printOfflineUsage(std::cerr, program);
    return 2;
  }
  if (help) {
    printOfflineUsage(std::cout, program);
    return 0;
  }
  try {
    const OfflineSummary s = runOffline(options, std::cerr);
    std::cout << s.metrics_json;
    std::cout << "wrote " << options.out_dir
              << "/{trajectory,landmarks,associations}.csv, map.txt, metrics.json"
              << (options.plot ? ", map.png" : "") << "\n";
  } catch (const std::exception& e) {
    std::cerr << program << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace ekf_slam
