# Tests (test/): one gtest file per unit. The files of one theme make one test executable, linked
# to the lowest layer they need and to GoogleTest's main(); each file's code sits in a namespace
# named after it. A rostest file has its own main() (it starts a ROS node). pluginlib dlopen()s
# the plugin libraries, so every test waits for them.
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

# ekf_slam_tests(NAME FILES file... LIBS lib... [PROGRAMS target...]): the test executable NAME
# from test/<file>.cpp, compiled as one unit (CMake's unity build, 8 files at most per unit): the
# files of a theme instantiate the same fixtures and GoogleTest code, which one unit compiles once
# (the six DJNN files: 11 s against 37 s; docs/benchmarks.md, "CI time"). With EKF_SLAM_PCH OFF,
# the build that checks that every file includes what it uses, each file compiles alone. Each
# program is built first and its path is the macro <TARGET>_BIN (EKF_SLAM_NODE_BIN for the node).
function(ekf_slam_tests name)
  cmake_parse_arguments(T "" "" "FILES;LIBS;PROGRAMS" ${ARGN})
  list(TRANSFORM T_FILES REPLACE "(.+)" "test/\\1.cpp")
  catkin_add_gtest(${name} ${T_FILES})
  target_link_libraries(${name} GTest::gtest_main ${T_LIBS})
  set_target_properties(${name} PROPERTIES UNITY_BUILD ${EKF_SLAM_PCH} UNITY_BUILD_BATCH_SIZE 8)
  _ekf_slam_test_setup(${name} "${T_PROGRAMS}")
endfunction()

# ekf_slam_rostest(NAME LAUNCH launch LIBS lib... [PROGRAMS target...]): test/NAME.cpp, with its
# own main(), run by rostest with test/<launch>.test.
function(ekf_slam_rostest name)
  cmake_parse_arguments(T "" "LAUNCH" "LIBS;PROGRAMS" ${ARGN})
  add_rostest_gtest(${name} test/${T_LAUNCH}.test test/${name}.cpp)
  target_link_libraries(${name} ${T_LIBS})
  _ekf_slam_test_setup(${name} "${T_PROGRAMS}")
endfunction()

function(_ekf_slam_test_setup name programs)
  target_include_directories(${name} PRIVATE test)
  target_compile_definitions(${name} PRIVATE EKF_SLAM_TEST_DATA="${PROJECT_SOURCE_DIR}/test/data")
  target_compile_options(${name} PRIVATE ${EKF_SLAM_TEST_OPTIONS})
  if(EKF_SLAM_PCH)
    target_precompile_headers(${name} REUSE_FROM ekf_slam_test_pch)
  endif()
  add_dependencies(${name} ekf_slam_association_plugins ekf_slam_relocalisation_plugins
                   ekf_slam_extraction_plugins)
  foreach(p ${programs})
    string(TOUPPER ${p}_BIN macro)
    if(p STREQUAL ekf_slam_node_main)
      set(macro EKF_SLAM_NODE_BIN)
    endif()
    add_dependencies(${name} ${p})
    target_compile_definitions(${name} PRIVATE ${macro}="$<TARGET_FILE:${p}>")
  endforeach()
endfunction()

# The estimator (ROS-free): the filter, association, DJNN, relocalisation and the lost rules.
ekf_slam_tests(tests_filter LIBS ekf_slam_core FILES
  test_chi2 test_parameters test_coverage_grid test_sensor_model test_observation_model
  test_motion_models test_ekf_slam test_ekf_storage test_first_estimate_jacobians test_invariant_ekf
  test_cartesian_observations test_landmark_index test_batch_smoother test_pose_clones)
ekf_slam_tests(tests_association LIBS ekf_slam_core ekf_slam_victoria_park FILES
  test_beacon_extractor test_tree_extractor test_association_context test_plugin_forwarding
  test_nn test_jcbb test_nnjcbb test_hungarian test_shape_context test_reweighted_random_walks
  test_rrwsc_matcher test_rrwsc)
ekf_slam_tests(tests_djnn LIBS ekf_slam_core FILES
  test_djnn test_djnn_detection test_djnn_admission test_djnn_tentative_pose test_djnn_joint
  test_djnn_remembered)
ekf_slam_tests(tests_relocalisation LIBS ekf_slam_core FILES
  test_geometric_constraints test_fgcbb test_rrwsc_relocaliser test_track_split test_lost_scans
  test_kidnap_onset test_scan_occlusion)

# The estimator on simulated worlds, and the test bench itself.
ekf_slam_tests(tests_pipeline LIBS ekf_slam_evaluation FILES
  test_slam_pipeline test_delayed_sightings test_scan_geometry test_input_sequencer
  test_pipeline_config test_odometry_correction test_compressed_ekf test_filter_consistency
  test_aekf_noise_model test_smoothing_recorder)
ekf_slam_tests(tests_recovery LIBS ekf_slam_evaluation FILES
  test_recovery test_recovery_window test_refused_lost_rule test_share_lost_rule
  test_lost_rollback)
ekf_slam_tests(tests_simulation LIBS ekf_slam_evaluation FILES
  test_simulator test_city_world test_beacon_car_park test_association_metrics
  test_trajectory_metrics test_simulated_run test_association_ceiling)

# Assembly: the builder, scan filter files, association problem files.
ekf_slam_tests(tests_app LIBS ekf_slam_app PROGRAMS replay_association FILES
  test_pipeline_builder test_scan_filter_chain test_replay_fuzz test_command_line
  test_replay_association)

# The ROS shell, and the offline runner on bags.
ekf_slam_tests(tests_ros LIBS ekf_slam_ros ekf_slam_gps_track FILES
  test_conversions test_victoria_park test_plugins test_extractor_plugins
  test_rrwsc_relocaliser_plugin test_gps_track)
ekf_slam_tests(tests_offline LIBS ekf_slam_offline_runner nlohmann_json::nlohmann_json
  PROGRAMS replay_association FILES test_ekf_reference test_bag_faults test_offline_runner)
ekf_slam_rostest(test_ros_parameter_source LAUNCH ros_parameter_source LIBS ekf_slam_ros)
ekf_slam_rostest(test_play_bag LAUNCH play_bag LIBS ekf_slam_ros)
# The node on a Victoria Park window, once per associator (the same launch file, the plugin
# given as a launch arg; DJNN is the default run), then bad input and unknown names.
ekf_slam_rostest(test_node LAUNCH node LIBS ekf_slam_node ekf_slam_offline_runner
                 PROGRAMS ekf_slam_node_main)
foreach(a NN JCBB NNJCBB Hungarian)
  add_rostest(test/node.test ARGS associator:=ekf_slam/${a} test_name:=node_${a}
              DEPENDENCIES test_node)
endforeach()
add_rostest(test/node_bad_input.test DEPENDENCIES test_node)
add_rostest(test/node_hold_tf.test DEPENDENCIES test_node)
ekf_slam_rostest(test_node_beacons LAUNCH node_beacons LIBS ekf_slam_offline_runner
                 PROGRAMS ekf_slam_node_main)
ekf_slam_rostest(test_node_faults LAUNCH node_faults
                 LIBS ekf_slam_offline_runner nlohmann_json::nlohmann_json
                 PROGRAMS ekf_slam_node_main)

# The tools, and every entry point against the others. The two longest runs have an executable
# each, so that ctest runs them beside the rest.
ekf_slam_tests(tests_tools LIBS ekf_slam_tools nlohmann_json::nlohmann_json PROGRAMS evaluate
  FILES test_simulate test_simulate_beacons test_evaluate_beacons test_evaluate
  test_offline_recovery test_offline_smoothing test_calibrate_noise)
ekf_slam_tests(tests_default_relocaliser LIBS ekf_slam_tools FILES test_default_relocaliser)
ekf_slam_tests(tests_entry_points LIBS ekf_slam_tools nlohmann_json::nlohmann_json
  PROGRAMS relocalisation_experiment detect_trees replay_association FILES test_entry_points)
ekf_slam_rostest(test_simulation_launch LAUNCH simulation LIBS ekf_slam_tools
                 PROGRAMS ekf_slam_node_main)
ekf_slam_rostest(test_kidnap_launch LAUNCH kidnap_launch LIBS ekf_slam_tools
                 PROGRAMS ekf_slam_node_main)

# The longest runs start first: a fresh clone has no ctest cost data, so ctest would start them in
# the order above and end on them (catkin names the tests).
set_tests_properties(
  _ctest_ekf_slam_rostest_test_kidnap_launch.test _ctest_ekf_slam_gtest_tests_default_relocaliser
  _ctest_ekf_slam_gtest_tests_tools _ctest_ekf_slam_gtest_tests_entry_points
  _ctest_ekf_slam_gtest_tests_offline PROPERTIES COST 100)
