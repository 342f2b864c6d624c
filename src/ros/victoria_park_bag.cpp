#include "ekf_slam/ros/victoria_park_bag.h"

#include <geometry_msgs/PointStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "ekf_slam/app/command_line.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/latched_topic.h"

namespace ekf_slam {
namespace victoria_park {

namespace {

// Variance of the components a planar vehicle cannot have (z, roll, pitch and their rates, and
// the lateral speed of the rear-axle centre): known to be zero, so small but not singular.
constexpr double kPlanarVariance = 1e-6;

ros::Time stampFromMs(std::int64_t ms) {
  // Integer split keeps the stamps exact (20967 ms -> 20 s 967000000 ns).
  return ros::Time(static_cast<std::uint32_t>(ms / 1000),
                   static_cast<std::uint32_t>((ms % 1000) * 1000000));
}

enum class Stream { kTfStatic = 0, kGps = 1, kOdom = 2, kScan = 3 };

struct Event {
  std::int64_t ms;
  Stream stream;
  std::size_t index;
};

sensor_msgs::LaserScan makeScan(const LaserScans& scans, std::size_t i) {
  sensor_msgs::LaserScan msg;
  msg.header.seq = static_cast<std::uint32_t>(i);  // detect_trees reports this as the scan index
  msg.header.stamp = stampFromMs(scans.time_ms[i]);
  msg.header.frame_id = "laser";
  msg.angle_min = static_cast<float>(-M_PI / 2);
  msg.angle_max = static_cast<float>(M_PI / 2);
  msg.angle_increment = static_cast<float>(M_PI / 360);
  // Per-beam timing is not in the data: consumers must treat a scan as instantaneous.
  msg.time_increment = 0.0f;
  msg.scan_time = 0.0f;
  msg.range_min = static_cast<float>(kRangeMin);
  msg.range_max = static_cast<float>(kRangeMax);
  const float no_return = static_cast<float>(kNoReturn);
  msg.ranges.resize(kBeams);
  for (int b = 0; b < kBeams; ++b) {
    const float r = scans.ranges[i][b];
    // REP-117: "no return" is +Inf, so it is not mistaken for an obstacle at range_max.
    msg.ranges[b] = r >= no_return ? std::numeric_limits<float>::infinity() : r;
  }
  return msg;
}

// Twist of base_link and its covariance from the inputs. The Jacobian is taken numerically from
// the core model so that the speed/yaw-rate equations exist only once.
void fillTwist(const AckermannModel& model, const OdometryNoise& noise, double v_e, double alpha,
               geometry_msgs::TwistWithCovariance* twist) {
  const double v = model.rearAxleSpeed(v_e, alpha);
  const double w = model.yawRate(v_e, alpha);
  const double hv = 1e-4, ha = 1e-6;
  const double dv_dve =
      (model.rearAxleSpeed(v_e + hv, alpha) - model.rearAxleSpeed(v_e - hv, alpha)) / (2 * hv);
  const double dv_da =
      (model.rearAxleSpeed(v_e, alpha + ha) - model.rearAxleSpeed(v_e, alpha - ha)) / (2 * ha);
  const double dw_dve =
      (model.yawRate(v_e + hv, alpha) - model.yawRate(v_e - hv, alpha)) / (2 * hv);
  const double dw_da = (model.yawRate(v_e, alpha + ha) - model.yawRate(v_e, alpha - ha)) / (2 * ha);
  const double s2v = noise.speed * noise.speed, s2a = noise.steering * noise.steering;

  twist->twist.linear.x = v;
  twist->twist.angular.z = w;
  auto& c = twist->covariance;
  std::fill(c.begin(), c.end(), 0.0);
  for (int k = 1; k < 5; ++k) c[k * 6 + k] = kPlanarVariance;
  c[0 * 6 + 0] = dv_dve * dv_dve * s2v + dv_da * dv_da * s2a;
  c[5 * 6 + 5] = dw_dve * dw_dve * s2v + dw_da * dw_da * s2a;
  c[0 * 6 + 5] = c[5 * 6 + 0] = dv_dve * dw_dve * s2v + dv_da * dw_da * s2a;
}

bool parseSeconds(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end != nullptr && *end == '\0' && std::isfinite(*value);
}

}  // namespace

BagCounts writeVictoriaParkBag(const BagOptions& options) {
  if (options.out_path.empty()) throw std::runtime_error("no output bag path given");
  if (options.start_s && options.end_s && *options.start_s > *options.end_s) {
    throw std::runtime_error("the window is inverted: --start " + std::to_string(*options.start_s) +
                             " > --end " + std::to_string(*options.end_s));
  }
  const std::string dir = options.data_dir.empty() ? defaultDataDir() : options.data_dir;
  const DeadReckoning dr = loadDeadReckoning(dir);
  const Gps gps = loadGps(dir);
  const LaserScans scans = loadLaser(dir);

  // Compare in ms with a tolerance so that "--start 20.967" includes the 20967 ms fix.
  auto in_window = [&](std::int64_t ms) {
    const double t = static_cast<double>(ms);
    return (!options.start_s || t >= *options.start_s * 1000.0 - 1e-6) &&
           (!options.end_s || t <= *options.end_s * 1000.0 + 1e-6);
  };

  std::vector<Event> events;
  events.reserve(dr.time_ms.size() + gps.time_ms.size() + scans.time_ms.size() + 1);
  for (std::size_t i = 0; i < gps.time_ms.size(); ++i) {
    if (in_window(gps.time_ms[i])) events.push_back({gps.time_ms[i], Stream::kGps, i});
  }
  for (std::size_t i = 0; i < dr.time_ms.size(); ++i) {
    if (in_window(dr.time_ms[i])) events.push_back({dr.time_ms[i], Stream::kOdom, i});
  }
  for (std::size_t i = 0; i < scans.time_ms.size(); ++i) {
    if (in_window(scans.time_ms[i])) events.push_back({scans.time_ms[i], Stream::kScan, i});
  }
  if (events.empty()) throw std::runtime_error("the time window contains no data");
  // Time order in the bag keeps chunks time-local, which makes playback and View cheap.
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.ms != b.ms ? a.ms < b.ms : a.stream < b.stream;
  });
  events.insert(events.begin(), Event{events.front().ms, Stream::kTfStatic, 0});

  rosbag::Bag bag;
  try {
    bag.open(options.out_path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(options.out_path + ": cannot open for writing (" + e.what() + ")");
  }

  // Odometry is integrated from pose 0 at the first sample of the whole data set, also for a
  // window, so that a windowed bag carries the same /odom poses as the full one.
  AckermannParams params;
  params.a = 0.0;
  params.b = 0.0;
  params.sigma_speed = options.odometry_noise.speed;
  params.sigma_steering = options.odometry_noise.steering;
  const AckermannModel model(params);
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
  std::size_t integrated = 0;  // samples whose pose is in `pose`, minus one

  BagCounts counts;
  counts.first_stamp = static_cast<double>(events.front().ms) / 1000.0;
  counts.last_stamp = static_cast<double>(events.back().ms) / 1000.0;
  try {
    for (const Event& e : events) {
      const ros::Time stamp = stampFromMs(e.ms);
      switch (e.stream) {
        case Stream::kTfStatic: {
          tf2_msgs::TFMessage msg;
          geometry_msgs::TransformStamped tf;
          tf.header.stamp = stamp;
          tf.header.frame_id = "base_link";
          tf.child_frame_id = "laser";
          tf.transform.translation.x = kLaserX;
          tf.transform.translation.y = kLaserY;
          tf.transform.rotation.w = 1.0;
          msg.transforms.push_back(tf);
          bag.write("/tf_static", stamp, msg,
                    latchedConnectionHeader("/victoria_park_to_bag", "/tf_static", msg));
          ++counts.tf_static;
          break;
        }
        case Stream::kGps: {
          geometry_msgs::PointStamped msg;
          msg.header.seq = static_cast<std::uint32_t>(e.index);
          msg.header.stamp = stamp;
          msg.header.frame_id = "gps";
          msg.point.x = gps.x[e.index];
          msg.point.y = gps.y[e.index];
          bag.write("/gps", stamp, msg);
          ++counts.gps;
          break;
        }
        case Stream::kOdom: {
          // Each sample's pose: the previous pose moved by the previous sample's inputs over the
          // actual time step.
          for (; integrated < e.index; ++integrated) {
            const std::size_t k = integrated;
            const double dt = static_cast<double>(dr.time_ms[k + 1] - dr.time_ms[k]) / 1000.0;
            const MotionStep s =
                model.step(pose, AckermannModel::Input(dr.speed[k], dr.steering[k]), dt);
            P = s.F * P * s.F.transpose() + s.Q;
            pose = s.pose;
          }
          nav_msgs::Odometry msg;
          msg.header.seq = static_cast<std::uint32_t>(e.index);
          msg.header.stamp = stamp;
          msg.header.frame_id = "odom";
          msg.child_frame_id = "base_link";
          msg.pose.pose = toPoseMsg(pose);
          msg.pose.covariance = toCovarianceMsg(P, kPlanarVariance);
          fillTwist(model, options.odometry_noise, dr.speed[e.index], dr.steering[e.index],
                    &msg.twist);
          bag.write("/odom", stamp, msg);
          ++counts.odometry;
          break;
        }
        case Stream::kScan: {
          bag.write("/scan", stamp, makeScan(scans, e.index));
          ++counts.scans;
          break;
        }
      }
    }
    bag.close();
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(options.out_path + ": write failed (" + e.what() + ")");
  }
  return counts;
}

void printBagUsage(std::ostream& out, const std::string& program) {
  out << "Usage: " << program << " [--data DIR] --out FILE.bag [--start SECONDS] [--end SECONDS]\n"
      << "\n"
      << "Converts ACFR's Victoria Park data set into a ROS bag: /scan (sensor_msgs/LaserScan,\n"
      << "frame laser, header.seq = scan index), /odom (nav_msgs/Odometry, odom -> base_link,\n"
      << "40 Hz), /gps (geometry_msgs/PointStamped, frame gps, metres) and a latched /tf_static\n"
      << "(base_link -> laser).\n"
      << "\n"
      << "  --data DIR       data folder (aa3_dr.mat, aa3_gpsx.mat, "
         "victoria_park_ascii/LASER.txt);\n"
      << "                   default $VP_DATA, else ../shared/data/victoria_park next to the\n"
      << "                   source tree (now: " << defaultDataDir() << ")\n"
      << "  --out FILE.bag   bag to write (overwritten)\n"
      << "  --start SECONDS  keep only messages stamped at or after SECONDS\n"
      << "  --end SECONDS    keep only messages stamped at or before SECONDS\n"
      << "  --help           this text\n"
      << "\n"
      << "Time: every stamp is the data's milliseconds / 1000, the clock `rosbag info` shows\n"
      << "(data from 20.967 s to 1570.540 s; the first GPS fix is at 20.967 s). --start/--end are\n"
      << "on that clock. /tf_static is stamped at the first message of the window. /odom poses\n"
      << "are integrated from pose 0 at the first sample of the whole data set, also in a "
         "window.\n";
}

bool parseBagArguments(const std::vector<std::string>& args, BagOptions* options, bool* help,
                       std::string* error) {
  CommandLine cl(args);
  std::string value;
  while (cl.next()) {
    if (cl.is("--data")) {
      cl.value(&options->data_dir);
    } else if (cl.is("--out")) {
      cl.value(&options->out_path);
    } else if (cl.is("--start") || cl.is("--end")) {
      double s = 0.0;
      if (!cl.value(&value)) break;
      if (!parseSeconds(value, &s)) {
        cl.fail(cl.flag() + ": '" + value + "' is not a number of seconds");
      } else {
        (cl.is("--start") ? options->start_s : options->end_s) = s;
      }
    } else {
      cl.unknown();
    }
  }
  if (!cl.finish(help, error)) return false;
  if (*help) return true;
  if (options->out_path.empty()) {
    *error = "--out FILE.bag is required";
    return false;
  }
  if (options->start_s && options->end_s && *options->start_s > *options->end_s) {
    *error = "--start must not be after --end";
    return false;
  }
  return true;
}

int victoriaParkToBagMain(int argc, char** argv) {
  const std::string program = argc > 0 ? argv[0] : "victoria_park_to_bag";
  BagOptions options;
  bool help = false;
  std::string error;
  if (!parseBagArguments(std::vector<std::string>(argv + std::min(argc, 1), argv + argc), &options,
                         &help, &error)) {
    std::cerr << program << ": " << error << "\n\n";
    printBagUsage(std::cerr, program);
    return 2;
  }
  if (help) {
    printBagUsage(std::cout, program);
    return 0;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    const BagCounts c = writeVictoriaParkBag(options);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "wrote " << options.out_path << ": " << c.scans << " scans, " << c.odometry
              << " odometry, " << c.gps << " GPS fixes, " << c.tf_static << " tf_static, stamps "
              << c.first_stamp << " s to " << c.last_stamp << " s, in " << seconds << " s\n";
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace victoria_park
}  // namespace ekf_slam
