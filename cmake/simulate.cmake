# Simulated worlds as bags (docs/simulation.md, "The simulate command"):
#   simulate --world NAME [--seed N] --out FILE.bag     (also writes FILE.yaml)
# played with launch/simulation.launch or replayed with ekf_slam_offline.

add_library(ekf_slam_simulation_bag src/ros/simulation_bag.cpp)
target_include_directories(ekf_slam_simulation_bag PUBLIC include)
target_link_libraries(ekf_slam_simulation_bag PUBLIC ekf_slam_evaluation ekf_slam_conversions ${catkin_LIBRARIES})
add_dependencies(ekf_slam_simulation_bag ${PROJECT_NAME}_generate_messages_cpp)

# `rosrun ekf_slam simulate`
add_executable(simulate src/nodes/simulate.cpp)
target_link_libraries(simulate ekf_slam_simulation_bag)
set_target_properties(simulate PROPERTIES OUTPUT_NAME simulate RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})

install(TARGETS ekf_slam_simulation_bag simulate
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)

  # Writes the tiny world's bag, reads it back, replays it with the offline runner (which loads
  # the plugins).
  catkin_add_gtest(test_simulate test/test_simulate.cpp)
  target_link_libraries(test_simulate ekf_slam_simulation_bag ekf_slam_offline_runner
                        nlohmann_json::nlohmann_json)
  add_dependencies(test_simulate ekf_slam_association_plugins)

  # The offline runner on simulated bags (loads the plugins): its recovery options on kidnapped
  # worlds, and --smooth.
  foreach(t test_offline_recovery test_offline_smoothing)
    catkin_add_gtest(${t} test/${t}.cpp)
    target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/test)
    target_link_libraries(${t} ekf_slam_simulation_bag ekf_slam_offline_runner
                          nlohmann_json::nlohmann_json)
    add_dependencies(${t} ekf_slam_association_plugins ekf_slam_relocalisation_plugins)
  endforeach()

  # launch/simulation.launch (node + rosbag play) on the tiny world's bag, started by the test
  # itself with roslaunch once it has written the bag and its YAML.
  add_rostest_gtest(test_simulation_launch test/simulation.test test/test_simulation_launch.cpp)
  target_include_directories(test_simulation_launch PRIVATE test)
  target_link_libraries(test_simulation_launch ekf_slam_simulation_bag ekf_slam_offline_runner)
  add_dependencies(test_simulation_launch ekf_slam_node_main ekf_slam_association_plugins
                   ekf_slam_extraction_plugins)
endif()
