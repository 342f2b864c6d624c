// readPipelineConfig: defaults, every name read, bad values name the parameter.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ekf_slam/core/pipeline/pipeline_config.h"

namespace ekf_slam {
namespace test_pipeline_config {

TEST(PipelineConfig, DefaultsWhenNothingIsSet) {
  const PipelineConfig c = readPipelineConfig(MapParameterSource());
  const PipelineConfig d;
  EXPECT_EQ(c.odometry_mode, "twist");
  EXPECT_DOUBLE_EQ(c.sigma_range, d.sigma_range);
  EXPECT_DOUBLE_EQ(c.sigma_bearing, d.sigma_bearing);
  EXPECT_DOUBLE_EQ(c.max_observation_range, d.max_observation_range);
  EXPECT_DOUBLE_EQ(c.twist.sigma_v, d.twist.sigma_v);
  EXPECT_DOUBLE_EQ(c.extractor.range_jump, d.extractor.range_jump);
  EXPECT_DOUBLE_EQ(c.index_cell_size, d.index_cell_size);
  EXPECT_DOUBLE_EQ(c.max_latency, d.max_latency);
  EXPECT_TRUE(c.initial_pose.isZero());
  EXPECT_TRUE(c.twist.additive.isZero());
}

TEST(PipelineConfig, ReadsEveryName) {
  MapParameterSource p;
  p.set("odometry_mode", "pose_delta");
  p.set("sigma_range", "0.3");
  p.set("sigma_bearing", "0.02");
  p.set("max_observation_range", "25");
  p.set("min_observation_range", "2");
  p.set("twist_sigma_v", "0.2");
  p.set("twist_sigma_w_per_v", "0.03");
  p.set("twist_additive_sigma_yaw", "0.1");
  p.set("pose_delta_alpha_rot_per_trans", "0.02");
  p.set("pose_delta_additive_sigma_x", "0.5");
  p.set("extractor_max_range", "60");
  p.set("extractor_occlusion_lookahead", "4");
  p.set("extractor_range_resolution", "0");
  p.set("initial_pose_x", "1.5");
  p.set("initial_pose_y", "-2");
  p.set("initial_pose_yaw", "0.7");
  p.set("initial_pose_sigma_yaw", "0.05");
  p.set("index_cell_size", "15");
  p.set("max_odometry_gap", "2");
  p.set("max_latency", "0.25");
  p.set("time_jump_threshold", "3");
  const PipelineConfig c = readPipelineConfig(p);
  EXPECT_EQ(c.odometry_mode, "pose_delta");
  EXPECT_DOUBLE_EQ(c.sigma_range, 0.3);
  EXPECT_DOUBLE_EQ(c.sigma_bearing, 0.02);
  EXPECT_DOUBLE_EQ(c.max_observation_range, 25.0);
  EXPECT_DOUBLE_EQ(c.min_observation_range, 2.0);
  EXPECT_DOUBLE_EQ(c.twist.sigma_v, 0.2);
  EXPECT_DOUBLE_EQ(c.twist.sigma_w_per_v, 0.03);
  EXPECT_DOUBLE_EQ(c.twist.additive(2, 2), 0.01);
  EXPECT_DOUBLE_EQ(c.pose_delta.alpha_rot_per_trans, 0.02);
  EXPECT_DOUBLE_EQ(c.pose_delta.additive(0, 0), 0.25);
  EXPECT_DOUBLE_EQ(c.extractor.max_range, 60.0);
  EXPECT_EQ(c.extractor.occlusion_lookahead, 4);
  EXPECT_DOUBLE_EQ(c.extractor.range_resolution, 0.0);
  EXPECT_TRUE(c.initial_pose.isApprox(Eigen::Vector3d(1.5, -2.0, 0.7)));
  EXPECT_DOUBLE_EQ(c.initial_pose_sigma.z(), 0.05);
  EXPECT_DOUBLE_EQ(c.index_cell_size, 15.0);
  EXPECT_DOUBLE_EQ(c.max_odometry_gap, 2.0);
  EXPECT_DOUBLE_EQ(c.max_latency, 0.25);
  EXPECT_DOUBLE_EQ(c.time_jump_threshold, 3.0);
}

// The error names the parameter (qualified by the source).
void expectError(const std::string& name, const std::string& value) {
  MapParameterSource p({}, "/ekf_slam/");
  p.set(name, value);
  try {
    readPipelineConfig(p);
    ADD_FAILURE() << name << " = " << value << " was accepted";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find("/ekf_slam/" + name), std::string::npos) << e.what();
  }
}

TEST(PipelineConfig, ReadsTheRecoveryParameters) {
  const PipelineConfig d;
  EXPECT_EQ(d.relocaliser, "ekf_slam/FGCBB");  // recovery on by default
  MapParameterSource p;
  p.set("relocaliser", "ekf_slam/FGCBB");
  p.set("lost_unpaired_scans", "4");
  p.set("lost_min_observations", "2");
  p.set("lost_min_expected", "5");
  p.set("lost_view_range", "20");
  p.set("lost_field_of_view", "6.2");
  p.set("lost_nis_scans", "0");
  p.set("lost_nis_probability", "0.99");
  p.set("relocalisation_window_scans", "3");
  const PipelineConfig c = readPipelineConfig(p);
  EXPECT_EQ(d.relocalisation_window_scans, 1);  // the current scan alone by default
  EXPECT_EQ(c.relocalisation_window_scans, 3);
  EXPECT_EQ(c.relocaliser, "ekf_slam/FGCBB");
  EXPECT_EQ(c.lost_unpaired_scans, 4);
  EXPECT_EQ(c.lost_min_observations, 2);
  EXPECT_EQ(c.lost_min_expected, 5);
  EXPECT_DOUBLE_EQ(c.lost_view_range, 20.0);
  EXPECT_DOUBLE_EQ(c.lost_field_of_view, 6.2);
  EXPECT_EQ(c.lost_nis_scans, 0);
  EXPECT_DOUBLE_EQ(c.lost_nis_probability, 0.99);
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, std::string>>{{"lost_unpaired_scans", "-1"},
                                                        {"lost_field_of_view", "7"},
                                                        {"lost_nis_probability", "1"},
                                                        {"lost_view_range", "-3"},
                                                        {"relocalisation_window_scans", "0"}}) {
    MapParameterSource bad;
    bad.set(name, value);
    try {
      readPipelineConfig(bad);
      ADD_FAILURE() << name << " = " << value << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

// "In view" for the lost rules can follow a camera's footprint (a convex polygon, sensor frame).
TEST(PipelineConfig, LostViewPolygon) {
  EXPECT_TRUE(PipelineConfig().lost_view_polygon.empty());
  MapParameterSource trapezoid;
  trapezoid.set("lost_view_polygon", "0.8,-0.5; 4.5,-1.5; 4.5,1.5; 0.8,0.5");
  const PipelineConfig c = readPipelineConfig(trapezoid);
  ASSERT_EQ(c.lost_view_polygon.size(), 4u);
  EXPECT_DOUBLE_EQ(c.lost_view_polygon[1].x(), 4.5);
  for (const char* bad : {"1,2; 3,4", "0,0; 1,1; 2,2", "0,0; 2,0; 1,1; 2,2; 0,2", "x"}) {
    MapParameterSource p;
    p.set("lost_view_polygon", bad);
    try {
      readPipelineConfig(p);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find("lost_view_polygon"), std::string::npos) << e.what();
    }
  }
}

TEST(PipelineConfig, BadValuesNameTheParameter) {
  expectError("odometry_mode", "ackermann");
  expectError("sigma_range", "0");
  expectError("sigma_bearing", "-1");
  expectError("sigma_range", "abc");
  expectError("twist_sigma_v", "-0.1");
  expectError("pose_delta_alpha_trans_per_rot", "nan");
  expectError("extractor_occlusion_lookahead", "1.5");
  expectError("min_observation_range", "40");  // >= max_observation_range
  expectError("index_cell_size", "0");
  expectError("initial_pose_x", "inf");
  expectError("max_latency", "-0.5");
  expectError("time_jump_threshold", "0");
}

TEST(PipelineConfig, OdometryCorrectionParameters) {
  const PipelineConfig d = readPipelineConfig(MapParameterSource());
  EXPECT_EQ(d.correction.mode, "none");
  EXPECT_DOUBLE_EQ(d.correction.wheel_factor_initial, 1.0);
  EXPECT_DOUBLE_EQ(d.correction.wheel_factor_sigma * d.correction.wheel_factor_sigma, 0.1);

  const MapParameterSource p({{"odometry_correction", "wheel_factors"},
                              {"correction_track_width", "1.6"},
                              {"correction_wheel_factor_initial", "1.1"},
                              {"correction_wheel_factor_sigma", "0.2"},
                              {"correction_wheel_factor_noise", "0.001"},
                              {"correction_speed_scale_noise", "0.002"},
                              {"correction_yaw_bias_sigma", "0.03"},
                              {"correction_factor_max", "1.5"}});
  const PipelineConfig c = readPipelineConfig(p);
  EXPECT_EQ(c.correction.mode, "wheel_factors");
  EXPECT_DOUBLE_EQ(c.correction.track_width, 1.6);
  EXPECT_DOUBLE_EQ(c.correction.wheel_factor_initial, 1.1);
  EXPECT_DOUBLE_EQ(c.correction.wheel_factor_sigma, 0.2);
  EXPECT_DOUBLE_EQ(c.correction.wheel_factor_noise, 0.001);
  EXPECT_DOUBLE_EQ(c.correction.speed_scale_noise, 0.002);
  EXPECT_DOUBLE_EQ(c.correction.yaw_bias_sigma, 0.03);
  EXPECT_DOUBLE_EQ(c.correction.factor_max, 1.5);

  expectError("odometry_correction", "gyro");
  expectError("correction_track_width", "0");
  expectError("correction_speed_scale_sigma", "0");
  expectError("correction_wheel_factor_noise", "-1");
  expectError("correction_speed_scale_initial", "-1");  // would reverse the speed
  expectError("correction_yaw_bias_max", "nan");

  // Cross-field checks name the parameter too.
  const auto expectInvalid = [](std::map<std::string, std::string> values,
                                const std::string& name) {
    try {
      readPipelineConfig(MapParameterSource(values));
      ADD_FAILURE() << name << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expectInvalid({{"odometry_correction", "speed_scale"}, {"odometry_mode", "pose_delta"}},
                "odometry_correction");
  expectInvalid({{"correction_speed_scale_initial", "3"}}, "correction_speed_scale_initial");
  expectInvalid({{"correction_factor_min", "2"}, {"correction_factor_max", "1.5"}},
                "correction_factor_max");
  expectInvalid({{"correction_yaw_bias_initial", "0.5"}}, "correction_yaw_bias_initial");
}

TEST(PipelineConfig, ValidateNamesTheField) {
  PipelineConfig c;
  c.sigma_bearing = 0.0;
  try {
    c.validate();
    ADD_FAILURE() << "accepted";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find("sigma_bearing"), std::string::npos) << e.what();
  }
  c = PipelineConfig();
  c.odometry_mode = "wheels";
  EXPECT_THROW(c.validate(), ParameterError);
}

}  // namespace test_pipeline_config
}  // namespace ekf_slam
