# Monte Carlo evaluation of the associators on the simulated worlds (issue 5): docs/results.md.
#   evaluate --world NAME --runs 20 --associators ekf_slam/NN,ekf_slam/DJNN --out DIR

add_library(ekf_slam_evaluate src/ros/evaluate.cpp)
target_link_libraries(ekf_slam_evaluate PUBLIC ekf_slam_ros ekf_slam_tools ekf_slam_evaluation)
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

if(CATKIN_ENABLE_TESTING)
  # One pipeline builder for every entry point (issue 35): a misspelt key is the same error in
  # each, and simulate + ekf_slam_offline gives evaluate's run exactly.
  catkin_add_gtest(test_entry_points test/test_entry_points.cpp)
  target_include_directories(test_entry_points PRIVATE test)
  target_link_libraries(test_entry_points ekf_slam_evaluate ekf_slam_simulation_bag
                        ekf_slam_offline_runner nlohmann_json::nlohmann_json)
  add_dependencies(test_entry_points ekf_slam_association_plugins ekf_slam_relocalisation_plugins
                   ekf_slam_extraction_plugins relocalisation_experiment detect_trees
                   replay_association)
  target_compile_definitions(test_entry_points PRIVATE
    EKF_SLAM_TEST_DATA="${PROJECT_SOURCE_DIR}/test/data"
    RELOCALISATION_EXPERIMENT_BIN="$<TARGET_FILE:relocalisation_experiment>"
    DETECT_TREES_BIN="$<TARGET_FILE:detect_trees>"
    REPLAY_ASSOCIATION_BIN="$<TARGET_FILE:replay_association>")
endif()
