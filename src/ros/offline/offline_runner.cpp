#include "ekf_slam/ros/offline/offline_runner.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include <geometry_msgs/PointStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/package.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>
#include <nlohmann/json.hpp>

#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"
#include "ekf_slam/core/pipeline/input_sequencer.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/ros/offline/checked_bag_reader.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/extractor_loader.h"
#include "ekf_slam/ros/plugin_loader.h"
#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/output_files.h"
#include "ekf_slam/app/yaml_configuration.h"

namespace ekf_slam {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

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

// --- bag contents --------------------------------------------------------------------------------

struct ScanInput {
  double stamp;
  LaserScanData data;
  std::string frame_id;
};
struct ObservationsInput {
  double stamp;
  std::vector<Observation> observations;
  std::vector<std::int64_t> truth_ids;
  std::string frame_id;
};

// Everything the run needs from the bag, read up front so that the processing loop measures the
// pipeline, not rosbag's decompression and deserialisation.
// Order of the inputs in the bag (what a live node would receive).
struct Arrival {
  enum Kind : std::uint8_t { kOdometry, kScan, kObservations } kind;
  std::uint32_t index;  // into the vector of that kind
};
// A scan handed to the sequencer: which vector, which entry.
struct InputRef {
  bool observations = false;
  std::uint32_t index = 0;
};

struct BagContents {
  std::vector<Arrival> arrivals;
  std::vector<OdometryInput> odometry;
  std::vector<ScanInput> scans;
  std::vector<ObservationsInput> observation_sets;
  std::vector<StampedPoint> gps;
  std::vector<geometry_msgs::TransformStamped> tf_static;
  std::vector<std::pair<double, Eigen::Vector3d>> ground_truth;    // (stamp, true pose)
  std::vector<std::pair<std::int64_t, Eigen::Vector2d>> true_map;  // (truth id, position)
  bool has_truth_ids = false;
  std::uint64_t observations_without_truth = 0;  // in a bag that has truth ids
};

// A message on a known topic with another type: the user's mistake, not corruption.
struct BadTopicType : std::runtime_error {
  using std::runtime_error::runtime_error;
};

BagContents readBag(const OfflineOptions& o) {
  // rosbag trusts the file's lengths: they are checked first.
  if (std::ifstream(o.bag_path).good()) {
    try {
      checkBagStructure(o.bag_path);
    } catch (const CorruptMessageError& e) {
      throw std::runtime_error("corrupted bag " + o.bag_path + ": " + e.what());
    }
  }
  rosbag::Bag bag;
  try {
    bag.open(o.bag_path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {  // rosbag's, or a corrupted header's
    throw std::runtime_error("cannot open bag " + o.bag_path + ": " + e.what());
  }
  BagContents c;
  // Every message is read through length checks: a corrupted bag stops the run with where it
  // was, never with an unbounded allocation (checked_bag_reader.h).
  CheckedBagReader reader;
  std::uint64_t read = 0;
  std::string topic = "(index)";
  double last_stamp = std::numeric_limits<double>::quiet_NaN();
  try {
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{
                               o.scan_topic, o.odom_topic, o.observations_topic, o.gps_topic,
                               o.tf_static_topic, o.ground_truth_topic, o.true_map_topic}));
    for (const rosbag::MessageInstance& m : view) {
      topic = m.getTopic();
      last_stamp = m.getTime().toSec();
      ++read;
      if (topic == o.odom_topic) {
        if (const auto msg = reader.instantiate<nav_msgs::Odometry>(m)) {
          c.arrivals.push_back({Arrival::kOdometry, static_cast<std::uint32_t>(c.odometry.size())});
          c.odometry.push_back(toOdometryInput(*msg));
          continue;
        }
      } else if (topic == o.scan_topic) {
        if (const auto msg = reader.instantiate<sensor_msgs::LaserScan>(m)) {
          c.arrivals.push_back({Arrival::kScan, static_cast<std::uint32_t>(c.scans.size())});
          c.scans.push_back({msg->header.stamp.toSec(), toScanData(*msg), msg->header.frame_id});
          continue;
        }
      } else if (topic == o.observations_topic) {
        if (const auto msg = reader.instantiate<LandmarkObservationArray>(m)) {
          ObservationsInput in{msg->header.stamp.toSec(), {}, {}, msg->header.frame_id};
          in.observations = toObservations(*msg, &in.truth_ids);
          for (const auto id : in.truth_ids) {
            c.has_truth_ids |= id != kNoTruthId;
            c.observations_without_truth += id == kNoTruthId;
          }
          c.arrivals.push_back(
              {Arrival::kObservations, static_cast<std::uint32_t>(c.observation_sets.size())});
          c.observation_sets.push_back(std::move(in));
          continue;
        }
      } else if (topic == o.gps_topic) {
        if (const auto msg = reader.instantiate<geometry_msgs::PointStamped>(m)) {
          c.gps.push_back({msg->header.stamp.toSec(), Eigen::Vector2d(msg->point.x, msg->point.y)});
          continue;
        }
      } else if (topic == o.ground_truth_topic) {
        if (const auto msg = reader.instantiate<nav_msgs::Odometry>(m)) {
          c.ground_truth.emplace_back(msg->header.stamp.toSec(), toOdometryInput(*msg).pose);
          continue;
        }
      } else if (topic == o.true_map_topic) {
        if (const auto msg = reader.instantiate<LandmarkArray>(m)) {
          c.true_map.clear();  // latched: the last one holds
          for (const auto& l : msg->landmarks)
            c.true_map.emplace_back(l.id, Eigen::Vector2d(l.x, l.y));
          continue;
        }
      } else if (topic == o.tf_static_topic) {
        if (const auto msg = reader.instantiate<tf2_msgs::TFMessage>(m)) {
          c.tf_static.insert(c.tf_static.end(), msg->transforms.begin(), msg->transforms.end());
          continue;
        }
      }
      throw BadTopicType(o.bag_path + ": topic " + topic + " has type " + m.getDataType() +
                         ", not the expected one");
    }
  } catch (const BadTopicType&) {
    throw;
  } catch (const std::exception& e) {  // CorruptMessageError, rosbag and ros exceptions
    std::ostringstream what;
    what << "corrupted bag " << o.bag_path << ": message " << read << " (topic " << topic
         << ", bag time " << std::fixed << std::setprecision(3) << last_stamp
         << " s) cannot be read: " << e.what() << "; " << c.scans.size() << " scans and "
         << c.odometry.size() << " odometry messages were read before it";
    throw std::runtime_error(what.str());
  }
  if (c.scans.empty() && c.observation_sets.empty()) {
    throw std::runtime_error(o.bag_path + ": no messages on " + o.scan_topic + " or " +
                             o.observations_topic + " (see --scan-topic / --observations-topic)");
  }
  if (c.odometry.empty()) {
    throw std::runtime_error(o.bag_path + ": no odometry on " + o.odom_topic +
                             " (see --odom-topic)");
  }
  return c;
}

// Sensor poses on the base frame per frame id, from the bag's static transforms (chains too),
// looked up once per frame with the node's rule (conversions.h, sensorOffset): a message whose
// frame has no transform (or no name) is skipped, counted and warned about, as the node does.
class SensorFrames {
 public:
  SensorFrames(const BagContents& c, const OfflineOptions& o, std::ostream& log)
      : o_(o), log_(log) {
    for (const auto& t : c.tf_static) buffer_.setTransform(t, "bag", /*is_static=*/true);
  }
  /// The offset of `frame`, or null (the message is skipped).
  const Eigen::Vector3d* offset(const std::string& frame) {
    auto it = offsets_.find(frame);
    if (it == offsets_.end()) {
      std::optional<Eigen::Vector3d> offset;
      try {
        offset = sensorOffset(buffer_, o_.base_frame, frame);
      } catch (const tf2::TransformException& e) {
        const std::string why = "no static transform " + o_.base_frame + " -> " +
                                (frame.empty() ? "(empty frame_id)" : frame) + " on " +
                                o_.tf_static_topic + " (" + e.what() + ")";
        log_ << "warning: " << why << ": its messages are skipped\n";
        missing_ += (missing_.empty() ? "" : "; ") + why;
      }
      it = offsets_.emplace(frame, offset).first;
    }
    if (!it->second) ++skipped_;
    return it->second ? &*it->second : nullptr;
  }
  std::uint64_t skipped() const { return skipped_; }
  /// Every missing transform, for the error when no message could be used.
  const std::string& missing() const { return missing_; }

 private:
  const OfflineOptions& o_;
  std::ostream& log_;
  tf2::BufferCore buffer_;
  std::unordered_map<std::string, std::optional<Eigen::Vector3d>> offsets_;
  std::uint64_t skipped_ = 0;
  std::string missing_;
};

// True pose at `stamp` from the ground-truth track (sorted by stamp): exact at a sample,
// interpolated between two, none outside the track.
bool truePoseAt(const std::vector<std::pair<double, Eigen::Vector3d>>& track, double stamp,
                Eigen::Vector3d* pose) {
  const auto it = std::lower_bound(
      track.begin(), track.end(), stamp,
      [](const std::pair<double, Eigen::Vector3d>& s, double t) { return s.first < t; });
  if (it == track.end()) return false;
  if (std::abs(it->first - stamp) < 1e-6) {
    *pose = it->second;
    return true;
  }
  if (it == track.begin()) return false;
  const auto& [t0, p0] = *(it - 1);
  const auto& [t1, p1] = *it;
  const double f = (stamp - t0) / (t1 - t0);
  *pose = p0 + f * (p1 - p0);
  (*pose)(2) = p0(2) + f * wrapAngle(p1(2) - p0(2));
  return true;
}

// One trajectory.csv row.
struct PoseRow {
  double stamp;
  Eigen::Vector3d pose;
  Eigen::Vector3d variance;    // diagonal of the pose covariance
  Eigen::Vector2d correction;  // odometry correction estimates (first correctionDim() used)
  Eigen::Vector2d correction_sd;
};
// One landmark_trace.csv row.
struct LandmarkTraceRow {
  std::uint32_t scan;
  double stamp;
  LandmarkId id;
  Eigen::Vector2d mean;
  Eigen::Vector3d cov;  // var_x, cov_xy, var_y
};
// One associations.csv row.
struct AssociationRow {
  std::uint32_t scan;
  std::uint32_t obs;
  double stamp;
  double range, bearing, diameter;
  Decision decision;
  LandmarkId landmark;
  std::int64_t truth_id;
  bool removal = false;  // a landmark removed after the scan (obs, range, ... empty)
};

// Stamps in full: epoch stamps (1.2e9 s) need 10 digits before the point and 9 after.
std::string stampText(double stamp) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.9f", stamp);
  return buf;
}

// --- statistics ----------------------------------------------------------------------------------

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// JSON has no NaN: unknown numbers become null.
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

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

// --- output --------------------------------------------------------------------------------------

std::string plotScript() {
  const std::string pkg = ros::package::getPath("ekf_slam");
  if (!pkg.empty()) return pkg + "/scripts/plot_map.py";
  return std::string(EKF_SLAM_SOURCE_DIR) + "/scripts/plot_map.py";
}

// CPU time of the calling thread: on a machine shared with other jobs it measures the loop's own
// work where the wall time also counts the time the other jobs held the CPU.
double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (const char ch : s) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

// --- smoothing (--smooth) ------------------------------------------------------------------------

// Smooths the run and writes trajectory_smoothed.csv and map_smoothed.txt; returns metrics.json's
// "smoothing" object (with the smoothed trajectory's GPS error when the bag has GPS, and its
// error against the true poses beside the filter's, the same way, when it has them).
nlohmann::json writeSmoothed(const std::string& dir, const SlamPipeline& pipeline,
                             const SmoothingRecorder& recorder,
                             const std::vector<StampedPoint>& gps,
                             const std::vector<std::pair<double, Eigen::Vector3d>>& truth,
                             std::ostream& log) {
  const SmoothingResult r = recorder.smooth(pipeline);
  const std::vector<SmoothingScan>& scans = recorder.scans();    // their poses: the filter's
  const std::vector<MapLandmark> map = pipeline.mapLandmarks();  // the result's first landmarks
  if (!r.ok) {
    log << "warning: --smooth: " << r.error << "; no smoothed outputs\n";
    return {{"ok", false}, {"error", r.error}};
  }
  std::ofstream traj = openOutput(dir + "/trajectory_smoothed.csv");
  traj.precision(17);
  traj << "stamp,x,y,yaw\n";
  std::vector<StampedPoint> track;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    const Eigen::Vector3d& p = r.poses[i];
    traj << stampText(scans[i].stamp) << ',' << p.x() << ',' << p.y() << ',' << p.z() << '\n';
    track.push_back({scans[i].stamp, pipeline.observationModel().sensorPose(p).head<2>()});
  }
  std::vector<MapLandmark> smoothed = map;
  for (std::size_t k = 0; k < smoothed.size(); ++k) {
    smoothed[k].position = r.landmarks[k].position;
    // A landmark nothing observed keeps the filter's covariance with its estimate.
    if (r.landmark_covariances[k].allFinite()) smoothed[k].covariance = r.landmark_covariances[k];
  }
  pipeline.saveMap(dir + "/map_smoothed.txt", smoothed);
  double moved = 0.0;
  for (std::size_t k = 0; k < map.size(); ++k)
    moved = std::max(moved, (smoothed[k].position - map[k].position).norm());
  nlohmann::json j = {{"ok", true},
                      {"converged", r.converged},
                      {"iterations", r.iterations},
                      {"initial_cost", r.initial_cost},
                      {"final_cost", r.final_cost},
                      {"degrees_of_freedom", r.degrees_of_freedom},
                      {"cost_per_dof", number(r.final_cost / r.degrees_of_freedom)},
                      {"observation_cost_per_residual", r.observation_cost_per_residual},
                      {"odometry_cost_per_residual", r.odometry_cost_per_residual},
                      {"observations", r.observations},
                      {"dropped_observations", r.dropped_observations},
                      {"removed_landmarks", r.landmarks.size() - map.size()},
                      {"largest_landmark_move_m", moved},
                      {"seconds", r.seconds}};
  if (!gps.empty()) {
    const TrajectoryError e = compareTrajectories(track, gps);
    j["gps_rmse_m"] = number(e.rmse_aligned);
    j["gps_median_error_m"] = number(e.median_aligned);
    j["gps_p95_error_m"] = number(e.p95_aligned);
    j["gps_alignment"] = {{"yaw", e.alignment.yaw},
                          {"x", e.alignment.translation.x()},
                          {"y", e.alignment.translation.y()}};
  }
  if (!truth.empty()) {
    // base_link positions, smoothed and as the filter wrote them, against the true ones.
    std::vector<StampedPoint> reference, smoothed_base, filter_base;
    for (const auto& [t, p] : truth) reference.push_back({t, p.head<2>()});
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      smoothed_base.push_back({scans[i].stamp, r.poses[i].head<2>()});
      filter_base.push_back({scans[i].stamp, scans[i].pose.head<2>()});
    }
    const TrajectoryError es = compareTrajectories(smoothed_base, reference);
    const TrajectoryError ef = compareTrajectories(filter_base, reference);
    j["truth_ate_aligned_m"] = number(es.rmse_aligned);
    j["truth_rmse_unaligned_m"] = number(es.rmse_unaligned);
    j["truth_ate_aligned_filter_m"] = number(ef.rmse_aligned);
    j["truth_rmse_unaligned_filter_m"] = number(ef.rmse_unaligned);
  }
  log << "smoothed in " << r.seconds << " s (" << r.iterations << " iterations, cost per dof "
      << r.final_cost / r.degrees_of_freedom << ")\n";
  return j;
}

}  // namespace

// -------------------------------------------------------------------------------------------------

OfflineSummary runOffline(const OfflineOptions& o, std::ostream& log) {
  if (o.bag_path.empty()) throw std::runtime_error("no bag given (--bag FILE)");
  if (o.out_dir.empty()) throw std::runtime_error("no output folder given (--out DIR)");

  // Parameters: one builder for every entry point (app/pipeline_builder.h), the options over
  // the file's `associator` and `relocaliser`.
  YamlConfiguration configuration(o.params_path);
  if (!o.associator.empty()) configuration.setOverride("", "associator", o.associator);
  if (!o.relocaliser.empty()) configuration.setOverride("", "relocaliser", o.relocaliser);
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
    throw std::runtime_error("--unknown-pose needs a relocaliser (--relocaliser NAME)");
  if (o.smooth && !o.load_map.empty())
    throw std::runtime_error(
        "--smooth cannot be used with --load-map (the smoother has no prior "
        "for the loaded landmarks)");
  if (!o.load_map.empty()) pipeline.loadMap(o.load_map, /*reset_pose=*/true, o.unknown_pose);

  makeDirectory(o.out_dir);

  // Bag reading is timed apart from the processing.
  const auto t_read = Clock::now();
  BagContents bag = readBag(o);
  const double bag_read_s = secondsSince(t_read);

  SensorFrames frames(bag, o, log);
  std::optional<Eigen::Vector3d> offset;  // of the first sensor message used (metrics.json)
  const std::string* current_frame = nullptr;

  std::vector<double> assoc_us, update_us;
  const std::size_t num_scans = bag.scans.size() + bag.observation_sets.size();
  assoc_us.reserve(num_scans);
  update_us.reserve(num_scans);
  std::vector<StampedPoint> laser_track;
  laser_track.reserve(num_scans);
  // The sensor track as estimated at each scan, before a relocalisation re-derived the lost ones.
  std::vector<StampedPoint> online_track;
  online_track.reserve(num_scans);
  SmoothingRecorder recorder;  // --smooth: what the batch smoother needs, scan by scan
  // Output rows are kept in memory and written after the loop, so that the wall time measures
  // the SLAM processing alone.
  std::vector<PoseRow> poses;
  poses.reserve(num_scans);
  std::vector<AssociationRow> rows;
  rows.reserve(8 * num_scans);
  std::vector<LandmarkTraceRow> trace;
  double extraction_s = 0.0, association_s = 0.0, update_s = 0.0;
  std::uint32_t scans_done = 0;
  bool dumped = false;
  const std::string dump_path =
      o.dump_problem_scan ? o.out_dir + "/problem_" + std::to_string(*o.dump_problem_scan) + ".json"
                          : std::string();

  // Ground-truth scoring (simulated bags): every observation must carry its truth id.
  // A simulated scan bag (simulate --world beacons) has no truth ids: its extracted features get
  // the /true_map landmark they point at from the true sensor pose (truthByProximity, as evaluate
  // scores the same run).
  const bool score_scans = !bag.scans.empty() && bag.observation_sets.empty() &&
                           !bag.ground_truth.empty() && !bag.true_map.empty();
  LandmarkId next_clutter = sim::kClutterIdBase;
  const bool score = score_scans || (bag.has_truth_ids && bag.observations_without_truth == 0 &&
                                     bag.scans.empty());
  if (bag.has_truth_ids && !score) {
    log << "warning: the bag has truth ids, but " << bag.observations_without_truth
        << " observations lack one" << (bag.scans.empty() ? "" : " and it has laser scans")
        << ": no truth metrics\n";
  }
  std::sort(bag.ground_truth.begin(), bag.ground_truth.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::unordered_map<LandmarkId, Eigen::Vector2d> true_map(bag.true_map.begin(),
                                                           bag.true_map.end());
  const auto newScorer = [&true_map]() {
    auto s = std::make_unique<RunScorer>();
    s->setTrueMap(true_map);
    return s;
  };
  auto scorer = newScorer();
  std::vector<std::int64_t> truth;

  // Relocalisation events, for metrics.json.
  nlohmann::json relocalisation_events = nlohmann::json::array();
  std::vector<double> relocalisation_us;

  // One processed scan: bookkeeping and output rows.
  const auto record = [&](const ScanReport& r, const ObservationsInput* input) {
    if (r.became_lost) {
      log << "lost at scan " << r.scan << " (stamp " << std::fixed << r.stamp << std::defaultfloat
          << "): " << r.lost_reason << "\n";
    }
    if (r.lost && !pipeline.lost() && !r.relocalised)
      log << "scan " << r.scan << ": " << r.lost_reason << "\n";
    if (r.relocalisation_attempted) {
      relocalisation_us.push_back(1e6 * r.relocalisation_s);
      if (r.relocalised) {
        const RelocalisationResult& x = r.relocalisation;
        log << "relocalised at scan " << r.scan << ": pose " << x.pose.transpose() << ", "
            << x.hypothesis_size << " pairings\n";
        relocalisation_events.push_back({{"scan", r.scan},
                                         {"stamp", r.stamp},
                                         {"pose", {x.pose.x(), x.pose.y(), x.pose.z()}},
                                         {"pairings", x.hypothesis_size},
                                         {"joint_mahalanobis", number(x.joint_mahalanobis)},
                                         {"nodes", x.nodes},
                                         {"time_us", 1e6 * r.relocalisation_s}});
      }
    }
    extraction_s += r.extraction_s;
    association_s += r.association_s;
    update_s += r.update_s;
    assoc_us.push_back(1e6 * r.association_s);
    update_us.push_back(1e6 * r.update_s);
    const Eigen::Vector3d x = pipeline.pose();
    const Eigen::Matrix3d P = pipeline.poseCovariance();
    // Pose and correction states only: activeEkf() does not bring a compressed filter up to date.
    const EkfSlam& filter = pipeline.activeEkf();
    poses.push_back({r.stamp, x, P.diagonal(), filter.correction(),
                     filter.correctionCovariance().diagonal().cwiseSqrt()});
    laser_track.push_back({r.stamp, pipeline.observationModel().sensorPose(x).head<2>()});
    online_track.push_back(laser_track.back());
    if (o.smooth) recorder.add(r, pipeline);  // applies r's lost path to its own scans
    // Relocalised: the rows of the scans processed while lost, and of those tracked before it
    // that the fix contradicts, take their re-derived poses.
    applyLostPath(
        r.lost_path, poses.size() - 1, [&poses](std::size_t i) { return poses[i].stamp; },
        [&](std::size_t i, const Eigen::Vector3d& p) {
          poses[i].pose = p;
          laser_track[i].position = pipeline.observationModel().sensorPose(p).head<2>();
        });
    Eigen::Vector3d true_pose;
    const bool have_pose = score && truePoseAt(bag.ground_truth, r.stamp, &true_pose);
    std::vector<LandmarkId> scan_truth;
    if (score_scans && have_pose) {
      scan_truth = truthByProximity(pipeline.observationModel().sensorPose(true_pose),
                                    r.observations, bag.true_map, &next_clutter);
    }
    truth.clear();
    for (std::size_t i = 0; i < r.observations.size(); ++i) {
      const Observation& ob = r.observations[i];
      const Decision d =
          i < r.association.decision.size() ? r.association.decision[i] : Decision::kRejected;
      const LandmarkId id =
          (d == Decision::kPaired || d == Decision::kNew) ? r.association.landmark[i] : kNoLandmark;
      const std::int64_t truth_id = input && i < r.input_index.size()
                                        ? input->truth_ids[r.input_index[i]]
                                    : i < scan_truth.size() ? scan_truth[i]
                                                            : kNoTruthId;
      truth.push_back(truth_id);
      rows.push_back({r.scan, static_cast<std::uint32_t>(i), r.stamp, ob.z.x(), ob.z.y(),
                      ob.descriptor, d, id, truth_id});
    }
    // Removals, so that the scores can be recomputed from associations.csv alone.
    for (const LandmarkId id : r.removed)
      rows.push_back(
          {r.scan, 0, r.stamp, 0.0, 0.0, 0.0, Decision::kRejected, id, kNoTruthId, true});
    // A scan without a true pose has no truth for its features either.
    if (score && (!score_scans || have_pose))
      scorer->addScan(r, truth, x, P, have_pose ? &true_pose : nullptr);
    if (o.landmark_trace) {
      const EkfSlam& f = pipeline.ekf();
      for (std::size_t k = 0; k < f.numLandmarks(); ++k) {
        const Eigen::Matrix2d C = f.landmarkCovariance(static_cast<int>(k));
        trace.push_back({r.scan, r.stamp, f.landmarkIds()[k], f.landmark(static_cast<int>(k)),
                         Eigen::Vector3d(C(0, 0), C(0, 1), C(1, 1))});
      }
    }
    if (o.on_scan) o.on_scan(r, pipeline);
    if (o.dump_problem_scan && r.scan == *o.dump_problem_scan) {
      capturing->disarm();
      // No associate() call (no observations): the state is the pre-association one anyway.
      const AssociationProblem problem =
          capturing->problem()
              ? *capturing->problem()
              : makeAssociationProblem(pipeline.ekf(), pipeline.observationModel(), r.observations);
      writeAssociationProblem(problem, dump_path);
      dumped = true;
    }
    ++scans_done;
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
          // Landmark ids start again: scoring restarts with the new map.
          scorer = newScorer();
          break;
        case InputSequencer<InputRef>::Kind::kScan:
          if (o.dump_problem_scan && scans_done == *o.dump_problem_scan) capturing->arm();
          for (const OfflineOptions::Kidnap& k : o.kidnaps) {
            if (k.scan != scans_done) continue;
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
            record(pipeline.processObservations(s.stamp, s.observations), &s);
          } else {
            const ScanInput& s = bag.scans[item.scan.index];
            const ScanReport r = pipeline.processScan(s.stamp, s.data);
            if (r.geometry_error && pipeline.counters().inconsistent_scans == 1) {
              log << "warning: scan at " << std::fixed << s.stamp << std::defaultfloat << ": "
                  << r.geometry_error << ": used for prediction only (and every such scan)\n";
            }
            if (!r.duplicate) record(r, nullptr);
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

  const auto t_write = Clock::now();
  {
    std::ofstream traj = openOutput(o.out_dir + "/trajectory.csv");
    traj.precision(17);  // doubles round-trip: runs can be compared to rounding (bench_cekf.sh)
    // Odometry correction states (AEKF), when configured: estimate and std dev columns.
    const std::vector<std::string> names = pipeline.odometryCorrection().names();
    traj << "stamp,x,y,yaw,var_x,var_y,var_yaw";
    for (const std::string& n : names) traj << ',' << n << ',' << n << "_sd";
    traj << '\n';
    for (const PoseRow& p : poses) {
      traj << stampText(p.stamp) << ',' << p.pose.x() << ',' << p.pose.y() << ',' << p.pose.z()
           << ',' << p.variance.x() << ',' << p.variance.y() << ',' << p.variance.z();
      for (std::size_t i = 0; i < names.size(); ++i)
        traj << ',' << p.correction(i) << ',' << p.correction_sd(i);
      traj << '\n';
    }
    std::ofstream assoc = openOutput(o.out_dir + "/associations.csv");
    assoc << "scan,stamp,obs,range,bearing,diameter,decision,landmark_id"
          << (bag.has_truth_ids || score_scans ? ",truth_id" : "") << "\n";
    for (const AssociationRow& a : rows) {
      assoc << a.scan << ',' << stampText(a.stamp) << ',';
      if (a.removal) {
        assoc << ",,,,removed," << a.landmark << (bag.has_truth_ids || score_scans ? "," : "")
              << '\n';
        continue;
      }
      assoc << a.obs << ',' << a.range << ',' << a.bearing << ',' << a.diameter << ','
            << toString(a.decision) << ',' << a.landmark;
      if (bag.has_truth_ids || score_scans) assoc << ',' << a.truth_id;
      assoc << '\n';
    }
  }
  if (o.landmark_trace) {
    std::ofstream lt = openOutput(o.out_dir + "/landmark_trace.csv");
    lt.precision(10);
    lt << "scan,stamp,id,x,y,var_x,cov_xy,var_y\n";
    for (const LandmarkTraceRow& t : trace) {
      lt << t.scan << ',' << stampText(t.stamp) << ',' << t.id << ',' << t.mean.x() << ','
         << t.mean.y() << ',' << t.cov(0) << ',' << t.cov(1) << ',' << t.cov(2) << '\n';
    }
  }
  if (o.dump_problem_scan && !dumped) {
    throw std::runtime_error("--dump-problem " + std::to_string(*o.dump_problem_scan) +
                             ": the run has only " + std::to_string(scans_done) + " scans");
  }

  // --- landmarks -------------------------------------------------------------------------------
  const EkfSlam& ekf = pipeline.ekf();
  {
    std::ofstream lm = openOutput(o.out_dir + "/landmarks.csv");
    lm.precision(17);
    lm << "id,x,y,var_x,cov_xy,var_y,diameter,times_observed\n";
    for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
      const LandmarkId id = ekf.landmarkIds()[k];
      const Eigen::Vector2d m = ekf.landmark(static_cast<int>(k));
      const Eigen::Matrix2d P = ekf.landmarkCovariance(static_cast<int>(k));
      const LandmarkInfo& info = pipeline.landmarkInfo(id);
      lm << id << ',' << m.x() << ',' << m.y() << ',' << P(0, 0) << ',' << P(0, 1) << ',' << P(1, 1)
         << ',' << info.diameter << ',' << info.times_observed << '\n';
    }
  }

  // The update's shapes (N, d) and their counts: bench_rank_update --replay times the run's rank
  // downdates alone, the floor of docs/benchmarks_vp.md at the run's exact sizes.
  {
    std::ofstream sh = openOutput(o.out_dir + "/update_shapes.csv");
    sh << "n,d,updates\n";
    for (const auto& [shape, count] : ekf.updateStats().shapes)
      sh << shape.first << ',' << shape.second << ',' << count << '\n';
  }

  // The final map in the ~save_map format, so that runs chain (--load-map).
  pipeline.saveMap(o.out_dir + "/map.txt");

  // --- ground truth (simulated bags), for the picture ------------------------------------------
  if (!bag.ground_truth.empty()) {
    std::ofstream g = openOutput(o.out_dir + "/ground_truth.csv");
    g << "stamp,x,y,yaw\n";
    for (const auto& [t, p] : bag.ground_truth)
      g << stampText(t) << ',' << p.x() << ',' << p.y() << ',' << p.z() << '\n';
  }
  if (!bag.true_map.empty()) {
    std::ofstream g = openOutput(o.out_dir + "/true_landmarks.csv");
    g << "truth_id,x,y\n";
    for (const auto& [id, p] : bag.true_map) g << id << ',' << p.x() << ',' << p.y() << '\n';
  }

  // --- GPS -------------------------------------------------------------------------------------
  TrajectoryError gps_error, gps_clean_error, gps_online_error;
  std::vector<bool> gps_faulty;
  if (!bag.gps.empty()) {
    gps_error = compareTrajectories(laser_track, bag.gps);
    gps_online_error =
        pipeline.counters().lost_path_poses + pipeline.counters().rederived_tracked_poses > 0
            ? compareTrajectories(online_track, bag.gps)
            : gps_error;
    // The same without the fixes the GPS track itself shows faulty (judged from the GPS and the
    // odometry only: trajectory_metrics.h, faultyGpsFixes).
    std::vector<StampedPoint> gps = bag.gps;
    std::vector<StampedSpeed> speeds;
    speeds.reserve(bag.odometry.size());
    for (const OdometryInput& od : bag.odometry) speeds.push_back({od.stamp, od.twist(0)});
    std::sort(gps.begin(), gps.end(),
              [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
    std::sort(speeds.begin(), speeds.end(),
              [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
    gps_faulty = faultyGpsFixes(gps, speeds);
    std::vector<StampedPoint> clean;
    for (std::size_t i = 0; i < gps.size(); ++i)
      if (!gps_faulty[i]) clean.push_back(gps[i]);
    gps_clean_error = compareTrajectories(laser_track, clean);
    // The fixes also in the map frame (inverse alignment), so the picture overlays them.
    const Eigen::Matrix2d Rt = gps_error.alignment.rotation().transpose();
    std::ofstream g = openOutput(o.out_dir + "/gps.csv");
    g << "stamp,x,y,x_map,y_map,faulty\n";
    for (std::size_t i = 0; i < gps.size(); ++i) {
      const StampedPoint& f = gps[i];
      const Eigen::Vector2d m = Rt * (f.position - gps_error.alignment.translation);
      g << stampText(f.stamp) << ',' << f.position.x() << ',' << f.position.y() << ',' << m.x()
        << ',' << m.y() << ',' << (gps_faulty[i] ? 1 : 0) << '\n';
    }
  }

  // --- metrics ---------------------------------------------------------------------------------
  const PipelineCounters& k = pipeline.counters();
  nlohmann::json j;
  j["associator"] = short_name;
  j["bag"] = o.bag_path;
  j["params"] = o.params_path;
  j["scans"] = scans_done;
  j["odometry_messages"] = bag.odometry.size();
  j["landmarks"] = ekf.numLandmarks();
  j["wall_time_s"] = wall_time_s;
  j["loop_cpu_s"] = loop_cpu_s;
  j["bag_read_s"] = bag_read_s;
  j["extraction_time_s"] = extraction_s;
  j["association_time_s"] = association_s;
  j["update_time_s"] = update_s;
  j["association_us_median"] = number(quantile(assoc_us, 0.5));
  j["association_us_p99"] = number(quantile(assoc_us, 0.99));
  j["update_us_median"] = number(quantile(update_us, 0.5));
  j["update_us_p99"] = number(quantile(update_us, 0.99));
  {
    // The EKF update's arithmetic, for its floor (docs/benchmarks_vp.md, scripts/bench_vp.sh).
    const UpdateStats& u = ekf.updateStats();
    const double w = u.rank_flops > 0.0 ? 1.0 / u.rank_flops : 0.0;
    j["update_flops"] = u.flops;
    j["update_rank_flops"] = u.rank_flops;
    j["update_rank_n"] = u.weighted_n * w;  // rank-flop-weighted state size N ...
    j["update_rank_d"] = u.weighted_d * w;  // ... and measurement dimension d
  }
  if (const CompressedEkf* c = pipeline.compressedEkf()) {
    // filter cekf (docs/cekf.md): its areas and global updates.
    const CompressedEkfStats& s = c->stats();
    j["cekf"] = {{"areas", s.phases},
                 {"compressed_areas", s.compressed_phases},
                 {"global_updates", s.global_updates},
                 {"closed_grown", s.grown},
                 {"closed_landmark_in_reach", s.landmark_in_reach},
                 {"closed_pairing_outside", s.pairing_outside},
                 {"closed_flush", s.flushes},
                 {"global_update_s", s.global_update_s},
                 {"global_update_flops", s.global_update_flops},
                 {"active_update_flops", c->activeUpdateFlops()},
                 {"max_active_states", s.max_active_states}};
  }
  j["sensor_offset"] = {offset->x(), offset->y(), offset->z()};
  const Eigen::Vector3d final_pose = ekf.pose();
  j["final_pose"] = {final_pose.x(), final_pose.y(), final_pose.z()};
  {
    // Final odometry correction estimates and std devs, by name (empty for mode none).
    nlohmann::json c = {{"mode", pipeline.odometryCorrection().params().mode}};
    const std::vector<std::string> names = pipeline.odometryCorrection().names();
    const Eigen::Vector2d sd = ekf.correctionCovariance().diagonal().cwiseSqrt();
    for (std::size_t i = 0; i < names.size(); ++i) {
      c[names[i]] = number(ekf.correction()(i));
      c[names[i] + "_sd"] = number(sd(i));
    }
    j["odometry_correction"] = c;
  }
  if (!bag.gps.empty()) {
    j["gps_rmse_m"] = number(gps_error.rmse_aligned);
    j["gps_rmse_online_m"] = number(gps_online_error.rmse_aligned);  // lost path not re-derived
    j["gps_rmse_clean_m"] = number(gps_clean_error.rmse_aligned);
    j["gps_faulty_fixes"] = std::count(gps_faulty.begin(), gps_faulty.end(), true);
    j["gps_median_error_clean_m"] = number(gps_clean_error.median_aligned);
    j["gps_p95_error_clean_m"] = number(gps_clean_error.p95_aligned);
    j["gps_rmse_unaligned_m"] = number(gps_error.rmse_unaligned);
    j["gps_max_error_m"] = number(gps_error.max_aligned);
    j["gps_median_error_m"] = number(gps_error.median_aligned);
    j["gps_p95_error_m"] = number(gps_error.p95_aligned);
    j["gps_points"] = gps_error.points;
    j["gps_fixes"] = bag.gps.size();
    j["gps_alignment"] = {{"yaw", gps_error.alignment.yaw},
                          {"x", gps_error.alignment.translation.x()},
                          {"y", gps_error.alignment.translation.y()}};
  }
  j["counters"] = {{"odometry", k.odometry},
                   {"scans", k.scans},
                   {"odometry_gaps", k.odometry_gaps},
                   {"rejected_odometry", k.rejected_odometry},
                   {"rejected_updates", k.rejected_updates},
                   {"invalid_ranges", k.invalid_ranges},
                   {"scans_before_odometry", k.scans_before_odometry},
                   {"late_odometry", k.late_odometry},
                   {"late_scans", k.late_scans},
                   {"empty_scans", k.empty_scans},
                   {"invalid_observations", k.invalid_observations},
                   {"invalid_associations", k.invalid_associations},
                   {"failed_initialisations", k.failed_initialisations},
                   {"clamped_corrections", k.clamped_corrections},
                   {"refused_correction_updates", k.refused_correction_updates},
                   {"sequencer_late_odometry", sequencer.counters().late_odometry},
                   {"sequencer_late_scans", sequencer.counters().late_scans},
                   {"released_by_latency", sequencer.counters().released_by_latency},
                   {"invalid_stamps", invalid_stamps},
                   {"zero_stamps", zero_stamps},
                   {"skipped_no_tf", frames.skipped()},
                   {"inconsistent_scans", k.inconsistent_scans},
                   {"duplicate_scans", k.duplicate_scans},
                   {"implausible_odometry", k.implausible_odometry},
                   {"invalid_orientations", k.invalid_orientations},
                   {"held_stamps", sequencer.counters().held},
                   {"dropped_out_of_range", sequencer.counters().dropped_out_of_range},
                   {"time_jumps", time_jumps},
                   {"lost_events", k.lost_events},
                   {"relocalisation_requests", k.relocalisation_requests},
                   {"relocalisation_attempts", k.relocalisation_attempts},
                   {"probes", k.probes},
                   {"lost_timeouts", k.lost_timeouts},
                   {"relocalisations", k.relocalisations},
                   {"relocalisations_ambiguous", k.relocalisations_ambiguous},
                   {"relocalisations_not_found", k.relocalisations_not_found},
                   {"relocalisations_unconfirmed", k.relocalisations_unconfirmed},
                   {"lost_path_poses", k.lost_path_poses},
                   {"rederived_tracked_poses", k.rederived_tracked_poses},
                   {"discarded_landmarks", k.discarded_landmarks}};
  j["relocaliser"] = relocaliser_short;
  j["lost_at_end"] = pipeline.lost();
  j["relocalisation_us_median"] = number(quantile(relocalisation_us, 0.5));
  // The whole cost of recovery, probes included (docs/relocalisation.md).
  j["relocalisation_time_s"] =
      1e-6 * std::accumulate(relocalisation_us.begin(), relocalisation_us.end(), 0.0);
  j["relocalisation_events"] = relocalisation_events;
  if (o.smooth)
    j["smoothing"] = writeSmoothed(o.out_dir, pipeline, recorder, bag.gps, bag.ground_truth, log);
  if (score) {
    const RunMetrics m = scorer->metrics(&pipeline);
    const double created_per_true =
        m.map.true_landmarks_seen > 0
            ? static_cast<double>(m.map.landmarks_created) / m.map.true_landmarks_seen
            : std::nan("");
    j["truth"] = {{"accuracy", m.counts.accuracy()},
                  {"precision", m.counts.precision()},
                  {"recall", m.counts.recall()},
                  {"f1", m.counts.f1()},
                  {"tp", m.counts.tp},
                  {"fp", m.counts.fp},
                  {"fn", m.counts.fn},
                  {"tn", m.counts.tn},
                  {"scored_scans", m.scans},
                  {"landmarks", m.map.landmarks},
                  {"true_landmarks_seen", m.map.true_landmarks_seen},
                  {"true_landmarks_mapped", m.map.true_landmarks_mapped},
                  {"spurious_landmarks", m.map.spurious},
                  {"non_landmarks", m.map.non_landmarks},
                  {"duplicates", m.map.duplicates},
                  {"unknown_pairings", m.unknown_pairings},
                  {"landmarks_created", m.map.landmarks_created},
                  {"landmarks_created_per_true_landmark", number(created_per_true)},
                  {"true_landmarks_findable", m.map.true_landmarks_findable},
                  {"true_landmarks_found", m.map.true_landmarks_found},
                  {"landmark_precision", m.map.landmark_precision},
                  {"landmark_recall", m.map.landmark_recall},
                  {"pairing_coverage", m.map.pairing_coverage},
                  {"pose_rmse_m", number(m.pose_rmse_m)},
                  {"heading_rmse_rad", number(m.heading_rmse_rad)},
                  {"pose_ate_aligned_m", number(m.pose_ate_aligned_m)},
                  {"heading_rmse_aligned_rad", number(m.heading_rmse_aligned_rad)},
                  {"map_rmse_aligned_m", number(m.map_rmse_aligned_m)},
                  {"map_rmse_landmarks", m.map_rmse_landmarks},
                  {"anees", number(m.anees)},
                  {"nees_scans", m.nees_scans},
                  {"association_us_mean", number(m.association_us_mean)},
                  {"ground_truth_poses", bag.ground_truth.size()}};
  }
  j["write_s"] = secondsSince(t_write);  // CSV files and this file, not the picture
  const std::string text = j.dump(2) + "\n";
  openOutput(o.out_dir + "/metrics.json") << text;

  // Nothing is dropped silently: every input that needed handling is reported.
  const std::uint64_t late = k.late_odometry + k.late_scans;
  const std::uint64_t out_of_range = sequencer.counters().dropped_out_of_range;
  if (k.rejected_odometry || k.rejected_updates || late || k.odometry_gaps || invalid_stamps ||
      k.invalid_observations || k.invalid_associations || k.failed_initialisations ||
      out_of_range || k.invalid_ranges || k.empty_scans || time_jumps || k.clamped_corrections ||
      zero_stamps || frames.skipped() || k.inconsistent_scans || k.duplicate_scans ||
      k.implausible_odometry || k.invalid_orientations) {
    log << "warning: " << k.rejected_odometry << " odometry messages rejected (non-finite), "
        << k.implausible_odometry << " rejected (twist beyond max_speed / max_yaw_rate), "
        << k.invalid_orientations << " rejected (no orientation, pose_delta), " << zero_stamps
        << " messages with a zero stamp skipped, " << frames.skipped()
        << " sensor messages skipped (no transform for their frame), " << k.inconsistent_scans
        << " scans with inconsistent angles (prediction only), " << k.duplicate_scans
        << " duplicate scans dropped, " << invalid_stamps
        << " messages with invalid stamps dropped, " << out_of_range
        << " messages dropped (stamp out of range of the other input), " << time_jumps
        << " time jumps (resets), " << k.empty_scans << " empty scans, " << k.invalid_ranges
        << " invalid ranges, " << k.late_odometry << " late odometry messages skipped, "
        << k.late_scans << " late scans, " << k.odometry_gaps << " odometry gaps, "
        << k.rejected_updates << " EKF updates refused, " << k.invalid_observations
        << " invalid observations, " << k.invalid_associations << " associator results fixed, "
        << k.failed_initialisations << " failed landmark initialisations, " << k.clamped_corrections
        << " odometry corrections clamped to their bounds (metrics.json: counters)\n";
  }

  // --- picture ---------------------------------------------------------------------------------
  if (o.plot) {
    const std::string cmd = "/usr/bin/python3 " + shellQuote(plotScript()) + " " +
                            shellQuote(o.out_dir) + " > /dev/null";
    const int rc = std::system(cmd.c_str());
    if (rc != 0) {
      log << "warning: map.png not written (" << plotScript() << " failed"
          << (WIFEXITED(rc) && WEXITSTATUS(rc) == 3 ? ": python3-matplotlib is missing" : "")
          << ")\n";
    }
  }

  OfflineSummary s;
  s.associator = short_name;
  s.scans = scans_done;
  s.odometry = bag.odometry.size();
  s.landmarks = ekf.numLandmarks();
  s.wall_time_s = wall_time_s;
  s.gps_rmse_m = bag.gps.empty() ? -1.0 : gps_error.rmse_aligned;
  s.relocalisations = k.relocalisations;
  s.metrics_json = text;
  return s;
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
         "  --relocaliser  e.g. FGCBB: lost-robot recovery (default: the YAML's 'relocaliser',\n"
         "        else off); its parameters come from its section of the YAML\n"
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
  *help = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      *help = true;
      return true;
    }
    if (a == "--no-plot") {
      o->plot = false;
      continue;
    }
    if (a == "--no-progress") {
      o->progress = false;
      continue;
    }
    if (a == "--unknown-pose") {
      o->unknown_pose = true;
      continue;
    }
    if (a == "--landmark-trace") {
      o->landmark_trace = true;
      continue;
    }
    if (a == "--smooth") {
      o->smooth = true;
      continue;
    }
    std::string* target = a == "--bag"                  ? &o->bag_path
                          : a == "--out"                ? &o->out_dir
                          : a == "--params"             ? &o->params_path
                          : a == "--associator"         ? &o->associator
                          : a == "--relocaliser"        ? &o->relocaliser
                          : a == "--load-map"           ? &o->load_map
                          : a == "--scan-topic"         ? &o->scan_topic
                          : a == "--odom-topic"         ? &o->odom_topic
                          : a == "--observations-topic" ? &o->observations_topic
                          : a == "--gps-topic"          ? &o->gps_topic
                          : a == "--tf-static-topic"    ? &o->tf_static_topic
                          : a == "--ground-truth-topic" ? &o->ground_truth_topic
                          : a == "--true-map-topic"     ? &o->true_map_topic
                          : a == "--base-frame"         ? &o->base_frame
                                                        : nullptr;
    const bool dump = a == "--dump-problem";
    const bool kidnap = a == "--kidnap";
    if (target == nullptr && !dump && !kidnap) {
      *error = "unknown argument '" + a + "'";
      return false;
    }
    if (i + 1 >= args.size()) {
      *error = a + " needs a value";
      return false;
    }
    const std::string& v = args[++i];
    if (kidnap) {
      OfflineOptions::Kidnap k;
      unsigned long scan = 0;
      double dx = 0, dy = 0, dyaw = 0;
      int used = 0;
      if (std::sscanf(v.c_str(), "%lu:%lf,%lf,%lf%n", &scan, &dx, &dy, &dyaw, &used) != 4 ||
          used != static_cast<int>(v.size()) || v[0] == '-' ||
          scan > std::numeric_limits<std::uint32_t>::max() ||
          !Eigen::Vector3d(dx, dy, dyaw).allFinite()) {
        *error = "--kidnap needs SCAN:DX,DY,DYAW (e.g. 2000:30,-20,1.5), got '" + v + "'";
        return false;
      }
      k.scan = static_cast<std::uint32_t>(scan);
      k.jump = Eigen::Vector3d(dx, dy, dyaw);
      o->kidnaps.push_back(k);
    } else if (dump) {
      char* end = nullptr;
      errno = 0;
      const unsigned long scan = std::strtoul(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || v[0] == '-' || errno != 0 ||
          scan > std::numeric_limits<std::uint32_t>::max()) {
        *error = "--dump-problem needs a scan index (0, 1, ...), got '" + v + "'";
        return false;
      }
      o->dump_problem_scan = static_cast<std::uint32_t>(scan);
    } else {
      *target = v;
    }
  }
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
