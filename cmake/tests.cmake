# Tests (test/): one gtest file per unit, each with its own main() (catkin's gtest links
# GTest::gtest only). A test links the lowest layer it needs; pluginlib dlopen()s the plugin
# libraries, so every test waits for them.
find_package(rostest REQUIRED)

# A precompiled header of its own for the tests (executables: the libraries' -fPIC one does not
# fit them): GoogleTest, Eigen and the standard library, which every test file parses. It takes
# about 9 % off the tests' compile time (docs/benchmarks.md, "CI time").
#
# The tests compile unoptimised: their own code sets up and checks, and the code they test is in
# the libraries, compiled at the build type's level. -O0 takes 20 % off a test file's compile
# time and costs the test run nothing measurable (docs/benchmarks.md, "CI time").
set(EKF_SLAM_TEST_OPTIONS -O0)
if(EKF_SLAM_PCH)
  file(WRITE ${CMAKE_BINARY_DIR}/test_pch_only.cpp "")
  add_library(ekf_slam_test_pch OBJECT ${CMAKE_BINARY_DIR}/test_pch_only.cpp)
  target_link_libraries(ekf_slam_test_pch PRIVATE GTest::gtest Eigen3::Eigen)
  target_compile_options(ekf_slam_test_pch PRIVATE ${EKF_SLAM_TEST_OPTIONS})
  target_precompile_headers(ekf_slam_test_pch PRIVATE <gtest/gtest.h> ${EKF_SLAM_PCH_HEADERS}
                            <fstream> <random>)
endif()

# ekf_slam_test(NAME [ROSTEST launch] LIBS lib... [PROGRAMS target...]): test/NAME.cpp linked to
# LIBS; with ROSTEST a rostest of test/<launch>.test. Each program is built first and its path is
# the macro <TARGET>_BIN (EKF_SLAM_NODE_BIN for the node).
function(ekf_slam_test name)
  cmake_parse_arguments(T "" "ROSTEST" "LIBS;PROGRAMS" ${ARGN})
  if(T_ROSTEST)
    add_rostest_gtest(${name} test/${T_ROSTEST}.test test/${name}.cpp)
  else()
    catkin_add_gtest(${name} test/${name}.cpp)
  endif()
  target_include_directories(${name} PRIVATE test)
  target_link_libraries(${name} ${T_LIBS})
  target_compile_definitions(${name} PRIVATE EKF_SLAM_TEST_DATA="${PROJECT_SOURCE_DIR}/test/data")
  target_compile_options(${name} PRIVATE ${EKF_SLAM_TEST_OPTIONS})
  if(EKF_SLAM_PCH)
    target_precompile_headers(${name} REUSE_FROM ekf_slam_test_pch)
  endif()
  add_dependencies(${name} ekf_slam_association_plugins ekf_slam_relocalisation_plugins
                   ekf_slam_extraction_plugins)
  foreach(p ${T_PROGRAMS})
    string(TOUPPER ${p}_BIN macro)
    if(p STREQUAL ekf_slam_node_main)
      set(macro EKF_SLAM_NODE_BIN)
    endif()
    add_dependencies(${name} ${p})
    target_compile_definitions(${name} PRIVATE ${macro}="$<TARGET_FILE:${p}>")
  endforeach()
endfunction()

# The estimator (ROS-free).
foreach(t test_chi2 test_parameters test_coverage_grid test_sensor_model
          test_observation_model test_motion_models test_ekf_slam test_ekf_storage
          test_first_estimate_jacobians test_cartesian_observations test_landmark_index
          test_beacon_extractor test_association_context test_plugin_forwarding test_nn test_jcbb
          test_nnjcbb test_hungarian test_shape_context test_reweighted_random_walks
          test_rrwsc_matcher test_rrwsc test_djnn test_djnn_detection test_djnn_admission
          test_djnn_tentative_pose test_djnn_joint test_djnn_remembered test_geometric_constraints test_fgcbb test_rrwsc_relocaliser
          test_batch_smoother test_pose_clones test_track_split test_lost_scans test_kidnap_onset
          test_scan_occlusion)
  ekf_slam_test(${t} LIBS ekf_slam_core)
endforeach()
ekf_slam_test(test_tree_extractor LIBS ekf_slam_core ekf_slam_victoria_park)

# The estimator on simulated worlds, and the test bench itself.
foreach(t test_slam_pipeline test_delayed_sightings test_scan_geometry test_input_sequencer test_pipeline_config
          test_odometry_correction test_recovery test_recovery_window test_refused_lost_rule
          test_share_lost_rule test_lost_rollback test_compressed_ekf test_filter_consistency test_aekf_noise_model
          test_smoothing_recorder test_simulator test_city_world test_beacon_car_park
          test_association_metrics test_trajectory_metrics test_simulated_run
          test_association_ceiling)
  ekf_slam_test(${t} LIBS ekf_slam_evaluation)
endforeach()

# Assembly: the builder, scan filter files, association problem files.
foreach(t test_pipeline_builder test_scan_filter_chain test_replay_fuzz test_command_line)
  ekf_slam_test(${t} LIBS ekf_slam_app)
endforeach()
ekf_slam_test(test_replay_association LIBS ekf_slam_app PROGRAMS replay_association)

# The ROS shell.
foreach(t test_conversions test_victoria_park test_plugins test_extractor_plugins
          test_rrwsc_relocaliser_plugin)
  ekf_slam_test(${t} LIBS ekf_slam_ros)
endforeach()
ekf_slam_test(test_gps_track LIBS ekf_slam_gps_track)
ekf_slam_test(test_ros_parameter_source ROSTEST ros_parameter_source LIBS ekf_slam_ros)
ekf_slam_test(test_play_bag ROSTEST play_bag LIBS ekf_slam_ros)
foreach(t test_ekf_reference test_bag_faults)
  ekf_slam_test(${t} LIBS ekf_slam_offline_runner nlohmann_json::nlohmann_json)
endforeach()
ekf_slam_test(test_offline_runner LIBS ekf_slam_offline_runner nlohmann_json::nlohmann_json
              PROGRAMS replay_association)
# The node on a Victoria Park window, once per associator (the same launch file, the plugin
# given as a launch arg; DJNN is the default run), then bad input and unknown names.
ekf_slam_test(test_node ROSTEST node LIBS ekf_slam_node ekf_slam_offline_runner
              PROGRAMS ekf_slam_node_main)
foreach(a NN JCBB NNJCBB Hungarian)
  add_rostest(test/node.test ARGS associator:=ekf_slam/${a} test_name:=node_${a}
              DEPENDENCIES test_node)
endforeach()
add_rostest(test/node_bad_input.test DEPENDENCIES test_node)
add_rostest(test/node_hold_tf.test DEPENDENCIES test_node)
ekf_slam_test(test_node_beacons ROSTEST node_beacons LIBS ekf_slam_offline_runner
              PROGRAMS ekf_slam_node_main)
ekf_slam_test(test_node_faults ROSTEST node_faults
              LIBS ekf_slam_offline_runner nlohmann_json::nlohmann_json
              PROGRAMS ekf_slam_node_main)

# The tools, and every entry point against the others.
foreach(t test_simulate test_simulate_beacons test_offline_recovery test_offline_smoothing
          test_evaluate_beacons test_calibrate_noise)
  ekf_slam_test(${t} LIBS ekf_slam_tools nlohmann_json::nlohmann_json)
endforeach()
ekf_slam_test(test_evaluate LIBS ekf_slam_tools PROGRAMS evaluate)
ekf_slam_test(test_default_relocaliser LIBS ekf_slam_tools)
ekf_slam_test(test_entry_points LIBS ekf_slam_tools nlohmann_json::nlohmann_json
              PROGRAMS relocalisation_experiment detect_trees replay_association)
ekf_slam_test(test_simulation_launch ROSTEST simulation LIBS ekf_slam_tools
              PROGRAMS ekf_slam_node_main)
ekf_slam_test(test_kidnap_launch ROSTEST kidnap_launch LIBS ekf_slam_tools
              PROGRAMS ekf_slam_node_main)
