# Tree extractor: the detect_trees command and its unit test.

add_executable(detect_trees src/nodes/detect_trees.cpp)
target_include_directories(detect_trees PRIVATE include ${catkin_INCLUDE_DIRS})
target_link_libraries(detect_trees ekf_slam_core ekf_slam_victoria_park ${catkin_LIBRARIES})
set_target_properties(detect_trees PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
install(TARGETS detect_trees RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # The test has its own main(), so no gtest_main is linked.
  catkin_add_gtest(test_tree_extractor test/test_tree_extractor.cpp)
  if(TARGET test_tree_extractor)
    target_link_libraries(test_tree_extractor ekf_slam_core ekf_slam_victoria_park)
  endif()
endif()
