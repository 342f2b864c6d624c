#include "ekf_slam/ros/node/markers.h"

#include <algorithm>
#include <cmath>

#include "ekf_slam/ros/conversions.h"

namespace ekf_slam {

namespace {

// chi2(2, 0.95): the 95 % ellipse of a 2D Gaussian is x^T P^-1 x = 5.991.
constexpr double kChi2_2_95 = 5.991464547107979;
// rviz refuses zero scales; anything below a millimetre is invisible anyway.
constexpr double kMinScale = 1e-3;

void setColor(visualization_msgs::Marker* m, float r, float g, float b, float a) {
  m->color.r = r;
  m->color.g = g;
  m->color.b = b;
  m->color.a = a;
}

}  // namespace

visualization_msgs::Marker& LandmarkMarkers::add() {
  if (used_ == array_.markers.size()) array_.markers.emplace_back();
  visualization_msgs::Marker& m = array_.markers[used_++];
  // Reset the fields a previous use may have set; strings and vectors keep their capacity.
  m.points.clear();
  m.colors.clear();
  m.text.clear();
  m.pose = geometry_msgs::Pose();
  m.pose.orientation.w = 1.0;
  m.lifetime = ros::Duration(0);
  m.frame_locked = false;
  return m;
}

const visualization_msgs::MarkerArray& LandmarkMarkers::build(const SlamPipeline& pipeline,
                                                              const std::string& frame_id,
                                                              const ros::Time& stamp) {
  used_ = 0;
  auto header = [&](visualization_msgs::Marker* m, const char* ns, int id, int type, int action) {
    m->header.frame_id = frame_id;
    m->header.stamp = stamp;
    m->ns = ns;
    m->id = id;
    m->type = type;
    m->action = action;
  };
  using visualization_msgs::Marker;

  if (clear_all_) {
    Marker& m = add();
    header(&m, "", 0, Marker::CYLINDER, Marker::DELETEALL);
    clear_all_ = false;
  }

  const EkfSlam& ekf = pipeline.ekf();
  const std::vector<LandmarkId>& ids = ekf.landmarkIds();
  current_.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const LandmarkId id = ids[k];
    const int marker_id = static_cast<int>(id);  // rviz ids are int32; ids stay far below
    const Eigen::Vector2d p = ekf.landmark(static_cast<int>(k));
    if (!p.allFinite()) continue;  // never happens with a healthy filter; never draw garbage
    current_.insert(id);
    const LandmarkInfo& info = pipeline.landmarkInfo(id);
    const double d = std::isfinite(info.diameter) && info.diameter > 0.0 ? info.diameter
                                                                         : style_.default_diameter;
    {
      Marker& m = add();
      header(&m, kLandmarks, marker_id, Marker::CYLINDER, Marker::ADD);
      m.pose.position.x = p.x();
      m.pose.position.y = p.y();
      m.pose.position.z = 0.5 * style_.height;
      m.scale.x = m.scale.y = std::max(d, kMinScale);
      m.scale.z = style_.height;
      setColor(&m, 0.1f, 0.8f, 0.2f, 0.9f);
    }
    if (style_.show_ellipses) {
      const Eigen::Matrix2d P = ekf.landmarkCovariance(static_cast<int>(k));
      // Closed-form eigen decomposition of the symmetric 2x2 [a b; b c].
      const double a = P(0, 0), b = 0.5 * (P(0, 1) + P(1, 0)), c = P(1, 1);
      const double mean = 0.5 * (a + c);
      const double radius = std::hypot(0.5 * (a - c), b);
      const double major = std::max(mean + radius, 0.0);
      const double minor = std::max(mean - radius, 0.0);
      if (std::isfinite(major) && std::isfinite(minor)) {
        Marker& m = add();
        // A flat cylinder scaled to the ellipse's diameters: one marker, no point list.
        header(&m, kEllipses, marker_id, Marker::CYLINDER, Marker::ADD);
        m.pose.position.x = p.x();
        m.pose.position.y = p.y();
        m.pose.position.z = 0.01;
        // Direction of the major axis.
        m.pose.orientation = toQuaternionMsg(0.5 * std::atan2(2.0 * b, a - c));
        m.scale.x = std::max(2.0 * std::sqrt(kChi2_2_95 * major), kMinScale);
        m.scale.y = std::max(2.0 * std::sqrt(kChi2_2_95 * minor), kMinScale);
        m.scale.z = 0.02;
        setColor(&m, 1.0f, 0.85f, 0.1f, 0.35f);
      }
    }
    if (style_.show_ids) {
      Marker& m = add();
      header(&m, kIds, marker_id, Marker::TEXT_VIEW_FACING, Marker::ADD);
      m.pose.position.x = p.x();
      m.pose.position.y = p.y();
      m.pose.position.z = style_.height + 0.5;
      m.scale.z = style_.text_size;
      m.text = std::to_string(id);
      setColor(&m, 1.0f, 1.0f, 1.0f, 0.9f);
    }
  }

  // Landmarks shown before and gone now (removed by the associator, or the map was replaced).
  for (const LandmarkId id : published_) {
    if (current_.count(id)) continue;
    for (const char* ns : {kLandmarks, kEllipses, kIds}) {
      Marker& m = add();
      header(&m, ns, static_cast<int>(id), Marker::CYLINDER, Marker::DELETE);
    }
  }
  published_.swap(current_);

  // Tentative features: one sphere list (DELETE when there are none: rviz warns on empty lists).
  const std::vector<TentativeFeature> tentative = pipeline.associator().tentativeFeatures();
  {
    Marker& m = add();
    header(&m, kTentative, 0, Marker::SPHERE_LIST,
           tentative.empty() ? Marker::DELETE : Marker::ADD);
    m.scale.x = m.scale.y = m.scale.z = 0.6;
    setColor(&m, 1.0f, 0.4f, 0.0f, 0.8f);
    m.points.reserve(tentative.size());
    for (const TentativeFeature& f : tentative) {
      if (!f.position.allFinite()) continue;
      geometry_msgs::Point pt;
      pt.x = f.position.x();
      pt.y = f.position.y();
      pt.z = 0.3;
      m.points.push_back(pt);
    }
  }

  // The vehicle: an arrow at the current pose, part of this latched array so that a late rviz
  // shows where the robot is, not only the map (~pose is a per-scan stream).
  const Eigen::Vector3d pose = pipeline.pose();
  if (pose.allFinite()) {
    Marker& m = add();
    header(&m, kVehicle, 0, Marker::ARROW, Marker::ADD);
    m.pose.position.x = pose.x();
    m.pose.position.y = pose.y();
    m.pose.position.z = 0.5;
    m.pose.orientation.z = std::sin(0.5 * pose.z());
    m.pose.orientation.w = std::cos(0.5 * pose.z());
    m.scale.x = 2.5 * style_.text_size;  // length: readable at the zoom the labels are
    m.scale.y = m.scale.z = 0.8 * style_.text_size;
    setColor(&m, 0.9f, 0.1f, 0.9f, 1.0f);
  }

  array_.markers.resize(used_);
  return array_;
}

}  // namespace ekf_slam
