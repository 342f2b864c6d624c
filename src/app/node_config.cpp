#include "ekf_slam/app/node_config.h"

namespace ekf_slam {

NodeConfig readNodeConfig(const ParameterSource& source) {
  const ParameterReader p(source);
  NodeConfig c;  // the defaults
  c.map_frame = p.text("map_frame", c.map_frame);
  c.odom_frame = p.text("odom_frame", c.odom_frame);
  c.base_frame = p.text("base_frame", c.base_frame);
  c.publish_tf = p.flag("publish_tf", c.publish_tf);
  c.publish_map_to_base = p.flag("publish_map_to_base", c.publish_map_to_base);
  c.publish_odom_tf = p.flag("publish_odom_tf", c.publish_odom_tf);
  c.hold_odom_tf = p.flag("hold_odom_tf", c.hold_odom_tf);
  c.transform_tolerance = p.nonNegative("transform_tolerance", c.transform_tolerance);
  c.transform_publish_period =
      p.nonNegative("transform_publish_period", c.transform_publish_period);
  c.diagnostics_period = p.nonNegative("diagnostics_period", c.diagnostics_period);
  c.visualization_rate = p.nonNegative("visualization_rate", c.visualization_rate);
  c.input_timeout = p.positive("input_timeout", c.input_timeout);
  c.queue_size = p.integer("queue_size", c.queue_size, 1, 10000000);
  c.map_file = p.text("map_file", c.map_file);
  c.initial_map = p.text("initial_map", c.initial_map);
  c.initial_map_unknown_pose = p.flag("initial_map_unknown_pose", c.initial_map_unknown_pose);
  c.markers.default_diameter = p.positive("marker_default_diameter", c.markers.default_diameter);
  c.markers.height = p.positive("marker_height", c.markers.height);
  c.markers.text_size = p.positive("marker_text_size", c.markers.text_size);
  c.markers.show_ids = p.flag("marker_show_ids", c.markers.show_ids);
  c.markers.show_ellipses = p.flag("marker_show_covariance", c.markers.show_ellipses);
  for (const std::string* frame : {&c.map_frame, &c.odom_frame, &c.base_frame}) {
    if (frame->empty()) p.fail("frames", "frame names must not be empty");
  }
  if (c.map_frame == c.odom_frame || c.map_frame == c.base_frame || c.odom_frame == c.base_frame) {
    p.fail("map_frame", "map_frame, odom_frame and base_frame must be three different frames");
  }
  // A tf frame has one parent: with both, base_frame would hang below map and below odom.
  if (c.publish_tf && c.publish_map_to_base && c.publish_odom_tf) {
    p.fail("publish_map_to_base", "publish_map_to_base and publish_odom_tf together give " +
                                      c.base_frame + " two parents (" + c.map_frame + " and " +
                                      c.odom_frame + "): choose one");
  }
  return c;
}

}  // namespace ekf_slam
