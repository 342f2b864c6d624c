#include "ekf_slam/tools/simulation_bag.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/message_traits.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/app/command_line.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/laser_scan_simulator.h"
#include "ekf_slam/evaluation/simulation/simulator.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/latched_topic.h"

namespace ekf_slam {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Variance of what a planar vehicle cannot do (z, roll, pitch, lateral speed, their rates): known
// to be zero, so small but not singular (as victoria_park_to_bag writes it).
constexpr double kPlanarVariance = 1e-6;
// Plugins (associators, relocalisers) whose world-dependent parameters go into the YAML (DJNN
// first: the default).
const char* const kAssociators[] = {"DJNN", "NN", "JCBB", "NNJCBB", "Hungarian", "FGCBB", "GCBB"};

ros::Time bagStamp(double sim_stamp) { return ros::Time(sim_stamp + sim::kStampOffset); }

sensor_msgs::LaserScan toScanMsg(const LaserScanData& d, const ros::Time& stamp,
                                 std::uint32_t seq) {
  sensor_msgs::LaserScan m;
  m.header.seq = seq;
  m.header.stamp = stamp;
  m.header.frame_id = "laser";
  m.angle_min = static_cast<float>(d.angle_min);
  m.angle_increment = static_cast<float>(d.angle_increment);
  m.angle_max = static_cast<float>(d.angle_min + d.angle_increment * (d.ranges.size() - 1));
  m.range_min = static_cast<float>(d.range_min);
  m.range_max = static_cast<float>(d.range_max);
  m.ranges = d.ranges;
  m.intensities = d.intensities;
  return m;
}

// The twist covariance the filter assumes for this sample (TwistModel::step: the standard
// deviations grow with |v|), so a consumer reading the covariance gets what the YAML configures.
void setTwistCovariance(const TwistModel& model, const Eigen::Vector2d& twist,
                        boost::array<double, 36>* c) {
  std::fill(c->begin(), c->end(), 0.0);
  for (int k = 1; k < 5; ++k) (*c)[k * 6 + k] = kPlanarVariance;
  const Eigen::Matrix2d n = model.twistCovariance(twist);  // (v, w): rows 0 and 5
  (*c)[0] = n(0, 0);
  (*c)[5] = (*c)[30] = n(0, 1);
  (*c)[35] = n(1, 1);
}

Landmark makeLandmark(LandmarkId id, const Eigen::Vector2d& p) {
  Landmark lm;
  lm.id = id;
  lm.x = p.x();
  lm.y = p.y();
  lm.covariance = {0.0, 0.0, 0.0, 0.0};  // truth: exact
  lm.diameter = kNaN;
  lm.evidence = 0;
  lm.times_observed = 0;
  return lm;
}

// One sphere list per point set: a single marker keeps the bag small even with 50 movers.
visualization_msgs::Marker pointsMarker(const std::string& ns, const ros::Time& stamp,
                                        const std::vector<Eigen::Vector2d>& points,
                                        const std::array<float, 4>& rgba,
                                        const std::array<double, 3>& scale, double z) {
  visualization_msgs::Marker m;
  m.header.frame_id = "map";
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = 0;
  m.type = visualization_msgs::Marker::SPHERE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = scale[0];
  m.scale.y = scale[1];
  m.scale.z = scale[2];
  m.color.r = rgba[0];
  m.color.g = rgba[1];
  m.color.b = rgba[2];
  m.color.a = rgba[3];
  m.points.reserve(points.size());
  for (const auto& p : points) {
    geometry_msgs::Point pt;
    pt.x = p.x();
    pt.y = p.y();
    pt.z = z;
    m.points.push_back(pt);
  }
  return m;
}

// rosparam reads YAML 1.1 (PyYAML): "1e-05" is a string there and infinity is ".inf". Numbers
// are written so that rosparam and yaml-cpp both read them back as the same number.
std::string yamlScalar(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  const bool numeric = !text.empty() && end != nullptr && *end == '\0' && !std::isspace(text[0]);
  if (numeric) {
    if (std::isnan(v)) return ".nan";
    if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
    // An integer stays one: an int parameter must not turn into a double.
    if (text.find_first_of(".eE") == std::string::npos) return text;
    char buf[40];
    for (int precision = 1; precision <= 17; ++precision) {
      std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
      if (std::strtod(buf, nullptr) == v) break;  // shortest text that reads back exactly
    }
    std::string s(buf);
    if (s.find('.') == std::string::npos) {
      const std::size_t e = s.find_first_of("eE");
      s.insert(e == std::string::npos ? s.size() : e, ".0");
    }
    return s;
  }
  const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '/' || ch == '.' ||
           ch == '-';
  });
  if (plain && text[0] != '-' && text[0] != '.') return text;
  std::string quoted = "'";
  for (const char ch : text) quoted += ch == '\'' ? std::string("''") : std::string(1, ch);
  return quoted + "'";
}

std::string formatDouble(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool parseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end != nullptr && *end == '\0' && errno == 0 && std::isfinite(*value);
}

bool parseUnsigned(const std::string& text, std::uint64_t* value) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char ch) {
        return std::isdigit(static_cast<unsigned char>(ch));
      })) {
    return false;
  }
  char* end = nullptr;
  errno = 0;
  *value = std::strtoull(text.c_str(), &end, 10);
  return errno == 0 && *end == '\0';
}

std::string worldList() {
  std::string s;
  for (const std::string& n : sim::worldNames()) s += (s.empty() ? "" : " ") + n;
  return s;
}

// A laser world's scans are ray-cast against its poles, cars and walls: point movers and point
// clutter would be in the truth topics but never in a scan. Empty when the options are fine.
std::string laserWorldProblem(const SimulationBagOptions& o) {
  if (!sim::laserWorld(o.world)) return "";
  if (!(o.movers && *o.movers > 0) && !(o.clutter_rate && *o.clutter_rate > 0.0) &&
      !o.detection_probability)
    return "";
  return "--movers, --clutter-rate and --detection-probability do not apply to the laser world '" +
         o.world +
         "': its scans are ray-cast against its poles, cars and walls (docs/simulation.md)";
}

}  // namespace

std::string defaultParamsPath(const std::string& bag_path) {
  const std::string ext = ".bag";
  if (bag_path.size() > ext.size() &&
      bag_path.compare(bag_path.size() - ext.size(), ext.size(), ext) == 0) {
    return bag_path.substr(0, bag_path.size() - ext.size()) + ".yaml";
  }
  return bag_path + ".yaml";
}

std::string simulationParamsYaml(
    const std::string& world_name, const std::map<std::string, std::string>& pipeline,
    const std::map<std::string, std::map<std::string, std::string>>& associators,
    const std::vector<std::string>& header_comment, const sim::ExtractorSetup& extractor) {
  std::ostringstream y;
  for (const std::string& line : header_comment) y << "# " << line << "\n";
  y << "\nassociator: ekf_slam/DJNN\n";
  if (!extractor.name.empty()) {
    y << "extractor: ekf_slam/" << extractor.name << "  # /scan: features from the laser\n";
  }
  y << "\n# --- pipeline (docs/parameters.md): sim::pipelineParametersFor(" << world_name
    << ") ---\n";
  for (const auto& [name, value] : pipeline) y << name << ": " << yamlScalar(value) << "\n";
  y << "\n# --- associators: the parameters that depend on the world "
       "(sim::associatorParametersFor: the sensor's datasheet, never the simulator's truth) ---\n";
  // In the order of kAssociators: DJNN, the default, first.
  for (const char* a : kAssociators) {
    const auto it = associators.find(a);
    if (it == associators.end()) continue;
    if (it->second.empty()) {
      y << a << ": {}\n";
      continue;
    }
    y << a << ":\n";
    for (const auto& [name, value] : it->second)
      y << "  " << name << ": " << yamlScalar(value) << "\n";
  }
  if (!extractor.name.empty()) {
    y << "\n# --- feature extractor (docs/feature_extraction.md): sim::extractorFor(" << world_name
      << ") ---\n"
      << extractor.name << ":\n";
    for (const auto& [name, value] : extractor.parameters)
      y << "  " << name << ": " << yamlScalar(value) << "\n";
  }
  return y.str();
}

std::string worldParamsYaml(const sim::World& world, const std::vector<std::string>& header_comment,
                            bool true_noise) {
  std::map<std::string, std::map<std::string, std::string>> assoc;
  for (const char* a : kAssociators) {
    auto p = sim::associatorParametersFor(world, a);
    if (!p.empty() || std::string(a) == "DJNN") assoc[a] = std::move(p);
  }
  std::map<std::string, std::string> pipeline = sim::pipelineParametersFor(world);
  if (true_noise)
    for (const auto& [name, value] : sim::trueNoiseParametersFor(world)) pipeline[name] = value;
  return simulationParamsYaml(world.name, pipeline, assoc, header_comment,
                              sim::extractorFor(world));
}

SimulationBagSummary writeSimulationBag(const SimulationBagOptions& options, std::ostream& log) {
  if (options.out_path.empty()) throw std::invalid_argument("no output bag path given (--out)");
  sim::World world = sim::makeWorld(options.world);  // throws listing the names
  if (options.clutter_rate) {
    if (!(std::isfinite(*options.clutter_rate) && *options.clutter_rate >= 0.0)) {
      throw std::invalid_argument("clutter rate must be a finite number >= 0");
    }
    world.clutter_rate = *options.clutter_rate;
  }
  if (options.movers) {
    if (*options.movers < 0) throw std::invalid_argument("the number of movers must be >= 0");
    world.movers.count = *options.movers;
  }
  if (options.detection_probability) {
    const double pd = *options.detection_probability;
    if (!(pd > 0.0 && pd <= 1.0))
      throw std::invalid_argument("the detection probability must lie in (0, 1]");
    world.sensor.detection_probability = pd;
    world.sensor.detection_probability_far = pd;
  }
  const std::string laser_problem = laserWorldProblem(options);
  if (!laser_problem.empty()) throw std::invalid_argument(laser_problem);
  world.validate();
  const std::uint64_t seed = options.seed.value_or(world.default_seed);

  SimulationBagSummary s;
  s.world = world.name;
  s.seed = seed;
  s.bag_path = options.out_path;
  s.landmarks = world.landmarks.size();
  s.movers = static_cast<std::size_t>(world.movers.count);

  rosbag::Bag bag;
  try {
    bag.open(options.out_path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(options.out_path + ": cannot open for writing (" + e.what() + ")");
  }

  // The /odom pose covariance: the odometry's own dead reckoning with the noise the filter
  // assumes (twistNoiseFor), grown from zero at the start pose, so it says how far the
  // odometry pose may have drifted.
  const TwistParams twist_noise = sim::twistNoiseFor(world);
  const TwistModel odom_model(twist_noise);
  Eigen::Matrix3d odom_cov = Eigen::Matrix3d::Zero();
  std::optional<sim::OdometrySample> previous;

  // A laser world's scans, ray-cast at the true sensor pose with runSimulation's noise stream,
  // replace the point observations.
  const std::optional<sim::CarPark> laser_world = sim::laserWorld(world.name);
  std::optional<sim::LaserScanSimulator> laser;
  if (laser_world) laser.emplace(laser_world->laser, laser_world->scene);
  sim::Random laser_noise(sim::Random::streamSeed(seed, sim::kLaserNoiseStream));

  std::uint32_t odom_seq = 0, obs_seq = 0;
  try {
    sim::Simulation simulation(world, seed);
    const ros::Time t0 = bagStamp(0.0);
    s.first_stamp = t0.toSec();
    s.last_stamp = s.first_stamp;

    {
      tf2_msgs::TFMessage msg;
      geometry_msgs::TransformStamped tf;
      tf.header.stamp = t0;
      tf.header.frame_id = "base_link";
      tf.child_frame_id = "laser";
      tf.transform.translation.x = world.sensor.offset.x();
      tf.transform.translation.y = world.sensor.offset.y();
      tf.transform.rotation = toQuaternionMsg(world.sensor.offset.z());
      msg.transforms.push_back(tf);
      bag.write("/tf_static", t0, msg, latchedConnectionHeader("/simulate", "/tf_static", msg));
    }
    {
      LandmarkArray msg;
      msg.header.stamp = t0;
      msg.header.frame_id = "map";
      for (std::size_t k = 0; k < world.landmarks.size(); ++k) {
        msg.landmarks.push_back(makeLandmark(static_cast<LandmarkId>(k), world.landmarks[k]));
      }
      bag.write("/true_map", t0, msg, latchedConnectionHeader("/simulate", "/true_map", msg));
    }
    if (options.markers && !world.landmarks.empty()) {
      visualization_msgs::MarkerArray msg;
      // Flat magenta discs on the ground, under the node's green landmark cylinders. Stamp zero
      // ("latest"): a static picture in the fixed frame.
      msg.markers.push_back(pointsMarker("true_landmarks", ros::Time(0), world.landmarks,
                                         {1.0f, 0.2f, 1.0f, 0.8f}, {1.2, 1.2, 0.05}, 0.02));
      bag.write("/true_map_markers", t0, msg,
                latchedConnectionHeader("/simulate", "/true_map_markers", msg));
    }

    for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
      if (e == sim::Simulation::Event::kOdometry) {
        const sim::OdometrySample& o = simulation.odometry();
        const ros::Time t = bagStamp(o.stamp);
        if (previous) {
          const MotionStep step =
              odom_model.step(previous->pose, previous->twist, o.stamp - previous->stamp);
          odom_cov = step.F * odom_cov * step.F.transpose() + step.Q;
          odom_cov = 0.5 * (odom_cov + odom_cov.transpose()).eval();  // rounding breaks symmetry
        }
        previous = o;

        nav_msgs::Odometry odom;
        odom.header.seq = odom_seq;
        odom.header.stamp = t;
        odom.header.frame_id = "odom";
        odom.child_frame_id = "base_link";
        odom.pose.pose = toPoseMsg(o.pose);
        odom.pose.covariance = toCovarianceMsg(odom_cov, kPlanarVariance);
        odom.twist.twist.linear.x = o.twist.x();
        odom.twist.twist.angular.z = o.twist.y();
        setTwistCovariance(odom_model, o.twist, &odom.twist.covariance);
        bag.write("/odom", t, odom);

        nav_msgs::Odometry truth;  // covariances stay zero: the truth is exact
        truth.header.seq = odom_seq;
        truth.header.stamp = t;
        truth.header.frame_id = "map";
        truth.child_frame_id = "base_link";
        truth.pose.pose = toPoseMsg(o.true_pose);
        truth.twist.twist.linear.x = o.true_twist.x();
        truth.twist.twist.angular.z = o.true_twist.y();
        bag.write("/ground_truth", t, truth);

        ++odom_seq;
        s.last_stamp = std::max(s.last_stamp, t.toSec());
        continue;
      }

      const sim::ObservationSet& set = simulation.observations();
      const ros::Time t = bagStamp(set.stamp);
      if (laser) {
        const Eigen::Vector3d sensor = composePose(set.true_pose, world.sensor.offset);
        bag.write("/scan", t, toScanMsg(laser->scan(sensor, &laser_noise), t, obs_seq));
        ++s.scans;
        ++obs_seq;
        s.last_stamp = std::max(s.last_stamp, t.toSec());
        continue;
      }
      LandmarkObservationArray msg;
      msg.header.seq = obs_seq;
      msg.header.stamp = t;
      msg.header.frame_id = "laser";
      msg.observations.reserve(set.observations.size());
      const std::vector<Observation> observations = set.toObservations();
      for (std::size_t i = 0; i < observations.size(); ++i) {
        const sim::SimObservation& z = set.observations[i];
        LandmarkObservation o = toObservationMsg(observations[i]);
        if (options.true_noise) o.covariance = {0.0, 0.0, 0.0, 0.0};  // the YAML's sigmas apply
        o.has_truth_id = true;
        o.truth_id = z.truth_id;
        msg.observations.push_back(o);
        if (sim::isStaticLandmark(z.truth_id)) {
          ++s.landmark_observations;
        } else if (sim::isClutter(z.truth_id)) {
          ++s.clutter_observations;
        } else {
          ++s.mover_observations;
        }
      }
      s.observations += set.observations.size();
      bag.write("/observations", t, msg);

      if (world.movers.count > 0) {
        const std::vector<Eigen::Vector2d> positions = simulation.moverPositions();
        LandmarkArray movers;
        movers.header.seq = obs_seq;
        movers.header.stamp = t;
        movers.header.frame_id = "map";
        for (std::size_t k = 0; k < positions.size(); ++k) {
          movers.landmarks.push_back(makeLandmark(sim::moverId(static_cast<int>(k)), positions[k]));
        }
        bag.write("/movers", t, movers);
        if (options.markers) {
          visualization_msgs::MarkerArray markers;
          markers.markers.push_back(pointsMarker("movers", t, positions, {1.0f, 0.1f, 0.1f, 0.9f},
                                                 {0.7, 0.7, 0.7}, 0.35));
          bag.write("/movers_markers", t, markers);
        }
      }
      ++obs_seq;
      s.last_stamp = std::max(s.last_stamp, t.toSec());
    }
    s.kidnaps = simulation.kidnapsApplied();
    bag.close();
  } catch (const std::exception& e) {
    // No half-written bag is left behind to be mistaken for a complete one.
    try {
      bag.close();
    } catch (const std::exception&) {
    }
    std::remove(options.out_path.c_str());
    if (dynamic_cast<const rosbag::BagException*>(&e) != nullptr) {
      throw std::runtime_error(options.out_path + ": write failed (" + e.what() + ")");
    }
    throw;
  }
  s.odometry = odom_seq;
  s.observation_sets = obs_seq - s.scans;
  s.duration_s = s.last_stamp - s.first_stamp;
  if (s.kidnaps > 0) log << "note: " << s.kidnaps << " kidnap event(s) in the run\n";

  if (options.write_params) {
    s.params_path =
        options.params_path.empty() ? defaultParamsPath(options.out_path) : options.params_path;
    std::vector<std::string> comment = {
        "ekf_slam parameters for a simulated bag: world " + world.name + ", seed " +
            std::to_string(seed) +
            (options.clutter_rate ? ", clutter rate " + formatDouble(world.clutter_rate) : "") +
            (options.movers ? ", " + std::to_string(world.movers.count) + " movers" : "") +
            (options.detection_probability
                 ? ", detection probability " + formatDouble(*options.detection_probability)
                 : "") +
            ".",
        world.description + ".",
        "Bag: " + std::filesystem::path(options.out_path).filename().string() +
            " (written with it by `rosrun ekf_slam simulate`, docs/simulation.md).",
        "Same layout as config/simulation.yaml: pipeline parameters at the top level, each",
        "associator's under its short name. Use it with",
        "  rosrun ekf_slam ekf_slam_offline --bag BAG --params THIS_FILE --out DIR",
        "  roslaunch ekf_slam simulation.launch bag:=BAG params:=THIS_FILE"};
    std::ofstream out(s.params_path);
    if (options.true_noise)
      comment.push_back(
          "--true-noise: observations without covariance, the simulator's own noise below.");
    out << worldParamsYaml(world, comment, options.true_noise);
    out.close();
    if (!out) throw std::runtime_error(s.params_path + ": cannot write the parameter file");
  }
  return s;
}

// --- command line --------------------------------------------------------------------------------

void printSimulateUsage(std::ostream& out, const std::string& program) {
  out << "Usage: " << program
      << " --world NAME --out FILE.bag [--seed N] [--params-out FILE | --no-params]\n"
      << "       [--clutter-rate X] [--movers N] [--detection-probability P] [--no-markers]\n"
      << "       [--true-noise]\n"
      << "       " << program << " --list | --help\n"
      << "\n"
      << "Simulates a world (docs/simulation.md) and writes it as a bag the ekf_slam node and\n"
      << "ekf_slam_offline read: /odom, /observations (with truth ids; /scan with intensities\n"
      << "for the beacons world), /ground_truth, /true_map,\n"
      << "/movers, /tf_static, and rviz markers /true_map_markers, /movers_markers. Stamps are\n"
      << "the simulation's plus 1 s. Also writes the matching parameter YAML.\n"
      << "\n"
      << "  --world NAME       world to simulate (--list shows them)\n"
      << "  --out FILE.bag     bag to write (overwritten)\n"
      << "  --seed N           run seed (default: the world's default seed)\n"
      << "  --params-out FILE  parameter YAML (default: FILE.bag with .bag replaced by .yaml)\n"
      << "  --no-params        write no parameter YAML\n"
      << "  --clutter-rate X   mean clutter returns per observation set (overrides the world's;\n"
      << "                     not beacons, whose scans are ray-cast)\n"
      << "  --movers N         number of moving objects (overrides the world's; not beacons)\n"
      << "  --detection-probability P\n"
      << "                     the sensor's P_D, the same everywhere in view (overrides the\n"
      << "                     world's; the parameter file states it; not beacons)\n"
      << "  --no-markers       leave out /true_map_markers and /movers_markers\n"
      << "  --true-noise       observations without covariance and the YAML's noise the\n"
      << "                     simulator's own (checking calibrate_noise, docs/calibration.md)\n"
      << "  --list             print the worlds with a one-line description\n"
      << "  --help             this text\n"
      << "\n"
      << "Then: rosrun ekf_slam ekf_slam_offline --bag FILE.bag --params FILE.yaml --out DIR\n"
      << "      roslaunch ekf_slam simulation.launch bag:=$PWD/FILE.bag\n";
}

void printWorldList(std::ostream& out) {
  std::size_t width = 0;
  const std::vector<std::string> names = sim::worldNames();
  for (const std::string& n : names) width = std::max(width, n.size());
  for (const std::string& n : names) {
    out << std::left << std::setw(static_cast<int>(width) + 2) << n << sim::makeWorld(n).description
        << "\n";
  }
}

bool parseSimulateArguments(const std::vector<std::string>& args, SimulationBagOptions* o,
                            SimulateAction* action, std::string* error) {
  *action = SimulateAction::kRun;
  bool params_out_given = false;
  CommandLine cl(args);
  std::string v;
  while (cl.next()) {
    if (cl.is("--list")) {
      *action = SimulateAction::kList;
      return true;
    }
    if (cl.is("--no-params")) {
      o->write_params = false;
    } else if (cl.is("--no-markers")) {
      o->markers = false;
    } else if (cl.is("--true-noise")) {
      o->true_noise = true;
    } else if (cl.is("--world")) {
      cl.value(&o->world);
    } else if (cl.is("--out")) {
      cl.value(&o->out_path);
    } else if (cl.is("--params-out")) {
      params_out_given = cl.value(&o->params_path);
    } else if (cl.is("--seed")) {
      std::uint64_t seed = 0;
      if (!cl.value(&v)) break;
      if (!parseUnsigned(v, &seed)) {
        cl.fail("--seed needs a non-negative integer, got '" + v + "'");
      }
      o->seed = seed;
    } else if (cl.is("--clutter-rate")) {
      double rate = 0.0;
      if (!cl.value(&v)) break;
      if (!parseDouble(v, &rate) || rate < 0.0) {
        cl.fail("--clutter-rate needs a number >= 0, got '" + v + "'");
      }
      o->clutter_rate = rate;
    } else if (cl.is("--detection-probability")) {
      double pd = 0.0;
      if (!cl.value(&v)) break;
      if (!parseDouble(v, &pd) || !(pd > 0.0 && pd <= 1.0)) {
        cl.fail("--detection-probability needs a number in (0, 1], got '" + v + "'");
      }
      o->detection_probability = pd;
    } else if (cl.is("--movers")) {
      std::uint64_t n = 0;
      if (!cl.value(&v)) break;
      if (!parseUnsigned(v, &n) || n > 100000) {
        cl.fail("--movers needs an integer in [0, 100000], got '" + v + "'");
      }
      o->movers = static_cast<int>(n);
    } else {
      cl.unknown();
    }
  }
  if (!cl.ok()) {
    *error = cl.error();
    return false;
  }
  if (cl.help()) {
    *action = SimulateAction::kHelp;
    return true;
  }
  if (o->world.empty()) {
    *error = "--world NAME is required (one of: " + worldList() + ")";
    return false;
  }
  const std::vector<std::string> names = sim::worldNames();
  if (std::find(names.begin(), names.end(), o->world) == names.end()) {
    *error = "unknown world '" + o->world + "'; available: " + worldList();
    return false;
  }
  if (o->out_path.empty()) {
    *error = "--out FILE.bag is required";
    return false;
  }
  *error = laserWorldProblem(*o);
  if (!error->empty()) return false;
  if (params_out_given && !o->write_params) {
    *error = "--params-out and --no-params contradict each other";
    return false;
  }
  if (params_out_given && o->params_path.empty()) {
    *error = "--params-out needs a file name";
    return false;
  }
  return true;
}

int simulateMain(int argc, char** argv) {
  const std::string program = "simulate";
  SimulationBagOptions options;
  SimulateAction action = SimulateAction::kRun;
  std::string error;
  if (!parseSimulateArguments(std::vector<std::string>(argv + std::min(argc, 1), argv + argc),
                              &options, &action, &error)) {
    std::cerr << program << ": " << error << "\n\n";
    printSimulateUsage(std::cerr, program);
    return 2;
  }
  if (action == SimulateAction::kHelp) {
    printSimulateUsage(std::cout, program);
    return 0;
  }
  if (action == SimulateAction::kList) {
    printWorldList(std::cout);
    return 0;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    const SimulationBagSummary s = writeSimulationBag(options, std::cerr);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(s.bag_path, ec);
    std::cout << std::fixed << std::setprecision(1) << "world " << s.world << ", seed " << s.seed
              << ": " << s.duration_s << " s simulated (bag clock " << s.first_stamp << " to "
              << s.last_stamp << " s)\n"
              << "  " << s.odometry << " odometry messages (/odom, /ground_truth), "
              << s.observation_sets << " observation sets, " << s.observations << " observations ("
              << s.landmark_observations << " of landmarks, " << s.mover_observations
              << " of movers, " << s.clutter_observations << " clutter)"
              << (s.scans > 0 ? ", " + std::to_string(s.scans) + " laser scans (/scan)" : "")
              << "\n"
              << "  " << s.landmarks << " landmarks, " << s.movers
              << (s.movers == 1 ? " mover" : " movers")
              << (s.kidnaps > 0 ? ", " + std::to_string(s.kidnaps) + " kidnap(s)" : "") << "\n"
              << "wrote " << s.bag_path;
    if (!ec) std::cout << " (" << static_cast<double>(bytes) / 1e6 << " MB)";
    if (!s.params_path.empty()) std::cout << " and " << s.params_path;
    std::cout << std::setprecision(2) << " in " << seconds << " s\n";
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace ekf_slam
