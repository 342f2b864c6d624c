# Tests of the ROS-free EKF-SLAM core (models and filter). Each test file has its own main():
# catkin's gtest setup links GTest::gtest only.
if(CATKIN_ENABLE_TESTING)
  foreach(t test_observation_model test_motion_models test_ekf_slam)
    catkin_add_gtest(${t} test/${t}.cpp)
    if(TARGET ${t})
      target_link_libraries(${t} ekf_slam_core)
    endif()
  endforeach()
endif()
