# Benchmarks (bench/): programs that print numbers, never test assertions on time.
# Plain programs: the whole pipeline on a synthetic Victoria-Park-sized run, the dense rank
# update's GFLOP/s (the floor of docs/benchmarks_vp.md), the full EKF against the CEKF
# (scripts/bench_cekf.sh), the RRW&SC relocaliser on seed 004's kidnapped scans, and the
# association ceiling of the simulated worlds (docs/results.md, "The ceiling").
add_executable(bench_pipeline bench/bench_pipeline.cpp)
target_link_libraries(bench_pipeline ekf_slam_core)
add_executable(bench_rank_update bench/bench_rank_update.cpp)
target_link_libraries(bench_rank_update ekf_slam_core)
add_executable(bench_cekf bench/bench_cekf.cpp)
target_link_libraries(bench_cekf ekf_slam_evaluation)
add_executable(bench_rrwsc_relocaliser bench/bench_rrwsc_relocaliser.cpp)
target_link_libraries(bench_rrwsc_relocaliser ekf_slam_evaluation)
add_executable(association_ceiling bench/association_ceiling.cpp)
target_link_libraries(association_ceiling ekf_slam_evaluation)
set(EKF_SLAM_BENCH_PROGRAMS bench_pipeline bench_rank_update bench_cekf bench_rrwsc_relocaliser
                            association_ceiling)

# Google Benchmark (a test dependency, so built with the tests): the associators
# (scripts/bench_association.sh), FGCBB against GCBB, the feature extractors, the smoother.
if(CATKIN_ENABLE_TESTING)
  find_package(benchmark QUIET)
  if(benchmark_FOUND)
    add_executable(bench_association bench/bench_association.cpp)
    target_link_libraries(bench_association ekf_slam_core benchmark::benchmark)
    add_executable(bench_relocalisation bench/bench_relocalisation.cpp)
    target_link_libraries(bench_relocalisation ekf_slam_core benchmark::benchmark)
    add_executable(bench_feature_extraction bench/bench_feature_extraction.cpp)
    target_link_libraries(bench_feature_extraction ekf_slam_core benchmark::benchmark)
    add_executable(bench_smoother bench/bench_smoother.cpp)
    target_link_libraries(bench_smoother ekf_slam_evaluation benchmark::benchmark)
    list(APPEND EKF_SLAM_BENCH_PROGRAMS bench_association bench_relocalisation
         bench_feature_extraction bench_smoother)
  else()
    message(STATUS "Google Benchmark not found: its benchmarks (bench_association, ...) are not built")
  endif()
endif()
set_target_properties(${EKF_SLAM_BENCH_PROGRAMS} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS ${EKF_SLAM_BENCH_PROGRAMS} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
