# Monte Carlo evaluation of the associators on the simulated worlds (issue 5): docs/results.md.
#   evaluate --world NAME --runs 20 --associators ekf_slam/NN,ekf_slam/DJNN --out DIR

add_library(ekf_slam_evaluate src/ros/evaluate.cpp)
target_link_libraries(ekf_slam_evaluate PUBLIC ekf_slam_ros ekf_slam_tools ekf_slam_node ekf_slam_evaluation)
add_dependencies(ekf_slam_evaluate ekf_slam_association_plugins)

add_executable(evaluate src/nodes/evaluate.cpp)
target_link_libraries(evaluate ekf_slam_evaluate)
set_target_properties(evaluate PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})

install(TARGETS ekf_slam_evaluate evaluate
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_evaluate test/test_evaluate.cpp)
  target_link_libraries(test_evaluate ekf_slam_evaluate)
  add_dependencies(test_evaluate evaluate ekf_slam_association_plugins)
  target_compile_definitions(test_evaluate PRIVATE EVALUATE_BIN="$<TARGET_FILE:evaluate>")
endif()
