# The test bench, ROS-free (include/ekf_slam/evaluation, src/evaluation). Nothing of the
# estimator or the node depends on it.
# The scorers: what the offline runner needs to score a simulated bag (not the simulator).
add_library(ekf_slam_scoring
  src/evaluation/scoring/association_metrics.cpp
  src/evaluation/scoring/trajectory_metrics.cpp
  src/evaluation/scoring/run_scorer.cpp)
target_include_directories(ekf_slam_scoring PUBLIC include)
target_link_libraries(ekf_slam_scoring PUBLIC ekf_slam_core)
# Simulated worlds and sensors, simulated runs and the association ceiling.
add_library(ekf_slam_evaluation
  src/evaluation/simulation/simulator.cpp
  src/evaluation/simulation/simulator_sensor_worlds.cpp
  src/evaluation/simulation/city_world.cpp
  src/evaluation/simulation/laser_scan_simulator.cpp
  src/evaluation/world_parameters.cpp
  src/evaluation/simulated_run.cpp
  src/evaluation/association_ceiling.cpp)
target_include_directories(ekf_slam_evaluation PUBLIC include)
target_link_libraries(ekf_slam_evaluation PUBLIC ekf_slam_scoring)
install(TARGETS ekf_slam_scoring ekf_slam_evaluation
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION})
