// Writing a latched topic into a bag: rosbag play latches a topic only when its connection
// header says so (bag writers: victoria_park_to_bag, simulate).
#pragma once

#include <string>

#include <ros/message_traits.h>
#include <ros/types.h>
#include <boost/make_shared.hpp>
#include <boost/shared_ptr.hpp>

namespace ekf_slam {

/// Connection header for rosbag::Bag::write(topic, time, msg, header) that marks `topic` latched.
template <typename M>
boost::shared_ptr<ros::M_string> latchedConnectionHeader(const std::string& callerid,
                                                         const std::string& topic, const M& msg) {
  auto header = boost::make_shared<ros::M_string>();
  (*header)["callerid"] = callerid;
  (*header)["topic"] = topic;
  (*header)["type"] = ros::message_traits::datatype(msg);
  (*header)["md5sum"] = ros::message_traits::md5sum(msg);
  (*header)["message_definition"] = ros::message_traits::definition(msg);
  (*header)["latching"] = "1";
  return header;
}

}  // namespace ekf_slam
