# The EKF update's performance (issue 14): the panel rank downdate, its reference test, storage
# test and the rank-update benchmark.
target_sources(ekf_slam_core PRIVATE ${PROJECT_SOURCE_DIR}/src/core/filter/symmetric_rank_update.cpp)

# Dense rank-d update P -= W W^T at a given size: the GFLOP/s that set the floor of
# docs/benchmarks_vp.md (scripts/bench_vp.sh runs it). A plain program, no dependency.
add_executable(bench_rank_update bench/bench_rank_update.cpp)
target_link_libraries(bench_rank_update ekf_slam_core)
set_target_properties(bench_rank_update PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS bench_rank_update RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # Every associator on a Victoria Park window against test/data/ekf_reference_vp.txt (made by
  # the dense EKF before the rework); converts the window itself, skips without the data.
  ekf_slam_gtest(test_ekf_reference ekf_slam_offline_runner)
  add_dependencies(test_ekf_reference ekf_slam_association_plugins)
  # Covariance storage: growth, removal in place, no allocation in the update (counts malloc).
  ekf_slam_gtest(test_ekf_storage ekf_slam_core)
endif()
