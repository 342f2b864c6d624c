# The ROS node (issue 4): message conversions, the ekf_slam node, its markers and its tests.

# Message <-> pipeline bridges, shared by the node and the offline runner.
add_library(ekf_slam_conversions src/ros/conversions.cpp)
target_include_directories(ekf_slam_conversions PUBLIC include)
target_link_libraries(ekf_slam_conversions PUBLIC ekf_slam_core ${catkin_LIBRARIES})
add_dependencies(ekf_slam_conversions ${PROJECT_NAME}_generate_messages_cpp)

# The node's ROS class and its markers.
add_library(ekf_slam_node src/ros/ekf_slam_node.cpp src/ros/markers.cpp)
target_link_libraries(ekf_slam_node PUBLIC ekf_slam_conversions ekf_slam_ros)
add_dependencies(ekf_slam_node ${PROJECT_NAME}_generate_messages_cpp
                 ekf_slam_association_plugins)

# `rosrun ekf_slam ekf_slam`
add_executable(ekf_slam_node_main src/nodes/ekf_slam_node_main.cpp)
target_link_libraries(ekf_slam_node_main ekf_slam_node)
set_target_properties(ekf_slam_node_main PROPERTIES OUTPUT_NAME ekf_slam
                                                    RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})

install(TARGETS ekf_slam_conversions ekf_slam_node ekf_slam_node_main
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(DIRECTORY launch rviz DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(FILES config/simulation.yaml config/robot.yaml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/config)
# GPS fixes as a path for rviz (victoria_park.launch).
catkin_install_python(PROGRAMS scripts/gps_path.py
  DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)

  catkin_add_gtest(test_conversions test/test_conversions.cpp)
  target_link_libraries(test_conversions ekf_slam_conversions)

  # The node on a Victoria Park window, once per associator (the same launch file, the plugin
  # given as a launch arg; DJNN is the default run), then bad input and an unknown plugin name.
  add_rostest_gtest(test_node test/node.test test/test_node.cpp)
  target_link_libraries(test_node ekf_slam_node ekf_slam_offline_runner)
  add_dependencies(test_node ekf_slam_node_main ekf_slam_association_plugins)
  target_compile_definitions(test_node PRIVATE
    EKF_SLAM_NODE_BIN="$<TARGET_FILE:ekf_slam_node_main>")
  foreach(a NN JCBB NNJCBB Hungarian)
    add_rostest(test/node.test ARGS associator:=ekf_slam/${a} test_name:=node_${a}
                DEPENDENCIES test_node)
  endforeach()
  add_rostest(test/node_bad_input.test DEPENDENCIES test_node)
  # A user's BeaconExtractor config through launch/ekf_slam.launch, and the offline runner.
  add_rostest_gtest(test_node_beacons test/node_beacons.test test/test_node_beacons.cpp)
  target_include_directories(test_node_beacons PRIVATE test)
  target_link_libraries(test_node_beacons ekf_slam_offline_runner)
  target_compile_definitions(test_node_beacons PRIVATE
    EKF_SLAM_TEST_DATA="${PROJECT_SOURCE_DIR}/test/data")
  add_dependencies(test_node_beacons ekf_slam_node_main ekf_slam_extraction_plugins
                   ekf_slam_association_plugins)
endif()

# The node and the offline runner on the all-faults window (issue 15).
if(CATKIN_ENABLE_TESTING)
  add_rostest_gtest(test_node_faults test/node_faults.test test/test_node_faults.cpp)
  target_include_directories(test_node_faults PRIVATE ${PROJECT_SOURCE_DIR}/test)
  target_link_libraries(test_node_faults ekf_slam_offline_runner nlohmann_json::nlohmann_json)
  add_dependencies(test_node_faults ekf_slam_node_main ekf_slam_association_plugins)
endif()
