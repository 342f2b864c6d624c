# Sensor model, observation models and process noise options (issue 13).
target_sources(ekf_slam_core PRIVATE ${PROJECT_SOURCE_DIR}/src/core/sensor_model.cpp
                                     ${PROJECT_SOURCE_DIR}/src/core/association/joint_ml.cpp
                                     ${PROJECT_SOURCE_DIR}/src/core/association/held_window.cpp
                                     ${PROJECT_SOURCE_DIR}/src/core/association/djnn_held_window.cpp)

if(CATKIN_ENABLE_TESTING)
  ekf_slam_gtest(test_sensor_model ekf_slam_core)
  ekf_slam_gtest(test_djnn_detection ekf_slam_core)
  ekf_slam_gtest(test_djnn_admission ekf_slam_core)
  ekf_slam_gtest(test_djnn_tentative_pose ekf_slam_core)
  ekf_slam_gtest(test_djnn_joint ekf_slam_core)
  ekf_slam_gtest(test_djnn_remembered ekf_slam_core)
  ekf_slam_gtest(test_djnn_held_window ekf_slam_core)
  ekf_slam_gtest(test_cartesian_observations ekf_slam_core)
endif()

