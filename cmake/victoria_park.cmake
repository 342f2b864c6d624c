# Victoria Park bag converter and its tests (included by the root CMakeLists.txt, which defines
# ekf_slam_core and the ROS-free reader ekf_slam_victoria_park).

add_library(ekf_slam_ros_tools src/ros/victoria_park_bag.cpp)
target_include_directories(ekf_slam_ros_tools PUBLIC include ${catkin_INCLUDE_DIRS})
target_link_libraries(ekf_slam_ros_tools ekf_slam_victoria_park ekf_slam_core ${catkin_LIBRARIES})
add_dependencies(ekf_slam_ros_tools ${catkin_EXPORTED_TARGETS})

# `rosrun ekf_slam victoria_park_to_bag` looks in devel/lib/ekf_slam.
add_executable(victoria_park_to_bag src/nodes/victoria_park_to_bag.cpp)
target_link_libraries(victoria_park_to_bag ekf_slam_ros_tools)
set_target_properties(victoria_park_to_bag PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})

install(TARGETS ekf_slam_ros_tools victoria_park_to_bag
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_victoria_park test/test_victoria_park.cpp)
  if(TARGET test_victoria_park)
    target_link_libraries(test_victoria_park ekf_slam_ros_tools ekf_slam_victoria_park
      ${catkin_LIBRARIES})
  endif()

  # tf2_ros only for the playback test; found on its own so that catkin_LIBRARIES is untouched.
  find_package(rostest REQUIRED)
  find_package(tf2_ros REQUIRED)
  add_rostest_gtest(test_play_bag test/play_bag.test test/test_play_bag.cpp)
  if(TARGET test_play_bag)
    target_include_directories(test_play_bag PRIVATE ${tf2_ros_INCLUDE_DIRS})
    target_link_libraries(test_play_bag ekf_slam_ros_tools ${tf2_ros_LIBRARIES}
      ${catkin_LIBRARIES})
  endif()
endif()
