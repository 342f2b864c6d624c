// RosParameterSource over a live parameter server (rostest: test/ros_parameter_source.test).
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/ros/ros_parameter_source.h"

namespace ekf_slam {
namespace {

TEST(RosParameterSource, ReadsTypedValuesInTheAssociatorNamespace) {
  ros::NodeHandle pnh("~");
  pnh.setParam("DJNN/sensor_range", 25.5);
  pnh.setParam("DJNN/admit_evidence", 3);
  pnh.setParam("DJNN/flag", true);
  pnh.setParam("DJNN/penalty_region", std::string("valid"));
  const RosParameterSource src(pnh, "DJNN");

  double d = 0.0;
  int i = 0;
  bool b = false;
  std::string s;
  ASSERT_TRUE(src.get("sensor_range", &d));
  EXPECT_DOUBLE_EQ(d, 25.5);
  ASSERT_TRUE(src.get("admit_evidence", &i));
  EXPECT_EQ(i, 3);
  ASSERT_TRUE(src.get("admit_evidence", &d));  // an integer is a valid number
  EXPECT_DOUBLE_EQ(d, 3.0);
  ASSERT_TRUE(src.get("flag", &b));
  EXPECT_TRUE(b);
  ASSERT_TRUE(src.get("penalty_region", &s));
  EXPECT_EQ(s, "valid");
  EXPECT_FALSE(src.get("not_set", &d));
  EXPECT_EQ(src.qualify("sensor_range"), ros::this_node::getName() + "/DJNN/sensor_range");

  DJNN djnn;
  djnn.configure(src);
  EXPECT_DOUBLE_EQ(djnn.params().paper.sensor.max_range, 25.5);
  EXPECT_EQ(djnn.params().paper.admit_evidence, 3);
}

TEST(RosParameterSource, WrongTypeNamesTheParameter) {
  ros::NodeHandle pnh("~");
  pnh.setParam("NN/individual_probability", std::string("high"));
  pnh.setParam("NN/count", 2.5);
  const RosParameterSource src(pnh, "NN");
  const std::string full = ros::this_node::getName() + "/NN/individual_probability";

  double d = 0.0;
  try {
    src.get("individual_probability", &d);
    FAIL() << "no error for a string where a number is expected";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find(full), std::string::npos) << e.what();
  }
  int i = 0;
  EXPECT_THROW(src.get("count", &i), ParameterError);

  NN nn;
  try {
    nn.configure(src);
    FAIL() << "NN accepted individual_probability = 'high'";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find(full), std::string::npos) << e.what();
  }
}

TEST(RosParameterSource, OutOfRangeValueNamesTheParameter) {
  ros::NodeHandle pnh("~");
  pnh.setParam("DJNN2/individual_probability", 1.5);
  const RosParameterSource src(pnh, "DJNN2");
  DJNN djnn;
  try {
    djnn.configure(src);
    FAIL() << "DJNN accepted individual_probability = 1.5";
  } catch (const ParameterError& e) {
    EXPECT_NE(
        std::string(e.what()).find(ros::this_node::getName() + "/DJNN2/individual_probability"),
        std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_ros_parameter_source");
  ros::NodeHandle nh;  // keeps the node alive for the parameter calls
  return RUN_ALL_TESTS();
}
