# Simulated worlds with ground truth and the association / pose scorer (ROS-free core):
# docs/simulation.md.
# (Sources: ekf_slam_evaluation in CMakeLists.txt.)

if(CATKIN_ENABLE_TESTING)
  foreach(t test_simulator test_association_metrics test_simulated_run
          test_filter_consistency test_aekf_noise_model test_smoothing_recorder)
    catkin_add_gtest(${t} ${PROJECT_SOURCE_DIR}/test/${t}.cpp)
    target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/test)
    target_link_libraries(${t} ekf_slam_evaluation)
  endforeach()
endif()
