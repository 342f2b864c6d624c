#include "ekf_slam/ros/offline/bag_input.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <geometry_msgs/PointStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/extractor_loader.h"
#include "ekf_slam/ros/offline/checked_bag_reader.h"

namespace ekf_slam {

namespace {

// A message on a known topic with another type: the user's mistake, not corruption.
struct BadTopicType : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace

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
  std::sort(c.ground_truth.begin(), c.ground_truth.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  return c;
}

SensorFrames::SensorFrames(const BagContents& c, const OfflineOptions& o, std::ostream& log)
    : o_(o), log_(log) {
  for (const auto& t : c.tf_static) buffer_.setTransform(t, "bag", /*is_static=*/true);
}

const Eigen::Vector3d* SensorFrames::offset(const std::string& frame) {
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

}  // namespace ekf_slam
