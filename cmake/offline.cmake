# Offline bag runner, trajectory metrics, Victoria Park end to end (issue 4).
#   ekf_slam_offline --bag FILE --out DIR [--params YAML] [--associator NAME] [--dump-problem SCAN]

# (Trajectory metrics are ROS-free: part of ekf_slam_evaluation.)

# The runner feeds the bag through the node's conversions, InputSequencer and SlamPipeline.
add_library(ekf_slam_offline_runner src/ros/offline_runner.cpp src/ros/checked_bag_reader.cpp)
target_include_directories(ekf_slam_offline_runner PUBLIC include)
target_link_libraries(ekf_slam_offline_runner
  PUBLIC ekf_slam_conversions ekf_slam_ros ekf_slam_tools ekf_slam_evaluation ${catkin_LIBRARIES}
  PRIVATE nlohmann_json::nlohmann_json)
add_dependencies(ekf_slam_offline_runner ${PROJECT_NAME}_generate_messages_cpp
                 ekf_slam_association_plugins)

add_executable(ekf_slam_offline src/nodes/ekf_slam_offline.cpp)
target_link_libraries(ekf_slam_offline ekf_slam_offline_runner)
set_target_properties(ekf_slam_offline PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})

install(TARGETS ekf_slam_offline_runner ekf_slam_offline
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
# Run as `python3 plot_map.py` by the offline runner, found in the package share folder.
install(FILES scripts/plot_map.py DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/scripts)
install(FILES config/victoria_park.yaml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/config)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_trajectory_metrics test/test_trajectory_metrics.cpp)
  target_link_libraries(test_trajectory_metrics ekf_slam_evaluation)

  # Converts a Victoria Park window itself (skips without the data); runs the plugins and the
  # replay command, so both must be built.
  catkin_add_gtest(test_offline_runner test/test_offline_runner.cpp)
  target_link_libraries(test_offline_runner ekf_slam_offline_runner nlohmann_json::nlohmann_json)
  add_dependencies(test_offline_runner replay_association ekf_slam_association_plugins)
  target_compile_definitions(test_offline_runner PRIVATE
    REPLAY_ASSOCIATION_BIN="$<TARGET_FILE:replay_association>")
endif()

# The Victoria Park relocalisation experiment of seed 001 paper 2 (docs/relocalisation.md):
#   relocalisation_experiment --bag B --params P --map-scans 0:1000 --test-scans 1000:2500 ...
add_executable(relocalisation_experiment src/nodes/relocalisation_experiment.cpp
                                         src/ros/relocalisation_experiment.cpp)
target_link_libraries(relocalisation_experiment ekf_slam_offline_runner
                      nlohmann_json::nlohmann_json)
add_dependencies(relocalisation_experiment ekf_slam_relocalisation_plugins)
set_target_properties(relocalisation_experiment PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS relocalisation_experiment RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

# Fault injection (issue 15): faulty copies of a Victoria Park window through the runner.
if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_bag_faults test/test_bag_faults.cpp)
  target_include_directories(test_bag_faults PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_link_libraries(test_bag_faults ekf_slam_offline_runner nlohmann_json::nlohmann_json)
  add_dependencies(test_bag_faults ekf_slam_association_plugins)
endif()
