# Compressed EKF (issue 14, docs/cekf.md): the filter selected by `filter: cekf`, its equality
# test against the full EKF.
target_sources(ekf_slam_core PRIVATE ${PROJECT_SOURCE_DIR}/src/core/filter/compressed_ekf.cpp)

if(CATKIN_ENABLE_TESTING)
  ekf_slam_gtest(test_compressed_ekf ekf_slam_evaluation)
  ekf_slam_gtest(test_city_world ekf_slam_evaluation)
endif()

# The large `city` world (include/ekf_slam/core/simulation/city_world.h).
target_sources(ekf_slam_evaluation PRIVATE ${PROJECT_SOURCE_DIR}/src/core/simulation/city_world.cpp)

# Full EKF vs CEKF on a simulated world: time per scan against map size (scripts/bench_cekf.sh).
add_executable(bench_cekf bench/bench_cekf.cpp)
target_link_libraries(bench_cekf ekf_slam_evaluation)
set_target_properties(bench_cekf PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS bench_cekf RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
