# The association ceiling of the simulated worlds (issue 11, docs/results.md "The ceiling"): the
# true-pose, true-map associations of every scan, in the evaluation library, its test and the
# program that tabulates it.
target_sources(ekf_slam_evaluation
               PRIVATE ${PROJECT_SOURCE_DIR}/src/core/evaluation/association_ceiling.cpp)

if(CATKIN_ENABLE_TESTING)
  ekf_slam_gtest(test_association_ceiling ekf_slam_evaluation)
endif()

add_executable(association_ceiling ${PROJECT_SOURCE_DIR}/bench/association_ceiling.cpp)
target_link_libraries(association_ceiling ekf_slam_evaluation)
set_target_properties(association_ceiling PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS association_ceiling RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
