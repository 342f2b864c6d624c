# SLAM pipeline (ROS-free core): pipeline, input sequencer, pipeline config (issue 4).
target_sources(ekf_slam_core PRIVATE
  ${PROJECT_SOURCE_DIR}/src/core/slam_pipeline.cpp
  ${PROJECT_SOURCE_DIR}/src/core/scan_geometry.cpp
  ${PROJECT_SOURCE_DIR}/src/core/input_sequencer.cpp
  ${PROJECT_SOURCE_DIR}/src/core/pipeline_config.cpp)

# Synthetic timing of a Victoria-Park-sized run (prints numbers, asserts nothing about time).
add_executable(bench_pipeline ${PROJECT_SOURCE_DIR}/bench/bench_pipeline.cpp)
target_link_libraries(bench_pipeline ekf_slam_core)
install(TARGETS bench_pipeline RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  foreach(t test_slam_pipeline test_scan_geometry test_input_sequencer test_pipeline_config test_odometry_correction
            test_recovery test_recovery_window test_refused_lost_rule test_share_lost_rule)
    catkin_add_gtest(${t} ${PROJECT_SOURCE_DIR}/test/${t}.cpp)
    target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/test)
    target_link_libraries(${t} ekf_slam_evaluation)  # some use simulated worlds
  endforeach()
endif()
