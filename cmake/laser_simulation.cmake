# Ray-casting laser with intensities and the `beacons` car park (ROS-free core), scored with
# BeaconExtractor: docs/feature_extraction.md.
# (laser_scan_simulator.cpp is part of ekf_slam_evaluation.)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_beacon_car_park ${PROJECT_SOURCE_DIR}/test/test_beacon_car_park.cpp)
  target_include_directories(test_beacon_car_park PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_link_libraries(test_beacon_car_park ekf_slam_evaluation)
  # `evaluate --world beacons` (ekf_slam_evaluate is defined in evaluate.cmake).
  catkin_add_gtest(test_evaluate_beacons ${PROJECT_SOURCE_DIR}/test/test_evaluate_beacons.cpp)
  target_include_directories(test_evaluate_beacons PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_link_libraries(test_evaluate_beacons ekf_slam_evaluate)
  add_dependencies(test_evaluate_beacons ekf_slam_association_plugins)
  # `simulate --world beacons` (LaserScans on /scan) replayed by ekf_slam_offline (simulate.cmake,
  # offline.cmake; loads the association and extraction plugins).
  catkin_add_gtest(test_simulate_beacons ${PROJECT_SOURCE_DIR}/test/test_simulate_beacons.cpp)
  target_include_directories(test_simulate_beacons PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_link_libraries(test_simulate_beacons ekf_slam_simulation_bag ekf_slam_offline_runner
                        nlohmann_json::nlohmann_json)
  add_dependencies(test_simulate_beacons ekf_slam_association_plugins
                   ekf_slam_extraction_plugins)
endif()
