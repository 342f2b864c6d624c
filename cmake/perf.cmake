# The EKF update's performance (issue 14): its reference test.

if(CATKIN_ENABLE_TESTING)
  # Every associator on a Victoria Park window against test/data/ekf_reference_vp.txt (made by
  # the dense EKF before the rework); converts the window itself, skips without the data.
  ekf_slam_gtest(test_ekf_reference ekf_slam_offline_runner)
  add_dependencies(test_ekf_reference ekf_slam_association_plugins)
endif()
