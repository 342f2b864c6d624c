# The test bench's programs (include/ekf_slam/tools, src/tools): simulated worlds as bags
# (`simulate`), Monte Carlo evaluation of the associators (`evaluate`), the relocalisation
# experiment on a bag (`relocalisation_experiment`), noise calibration from a bag
# (`calibrate_noise`).
# Noise calibration (ROS-free, core/smoothing) is linked here, not in ekf_slam_core: only
# calibrate_noise uses it.
add_library(ekf_slam_tools
  src/core/smoothing/noise_calibration.cpp
  src/tools/simulation_bag.cpp
  src/tools/evaluate.cpp
  src/tools/relocalisation_experiment.cpp
  src/tools/calibrate_noise.cpp)
target_link_libraries(ekf_slam_tools PUBLIC ekf_slam_offline_runner ekf_slam_evaluation
                                            ekf_slam_ros PRIVATE nlohmann_json::nlohmann_json)

add_executable(simulate src/nodes/simulate.cpp)
add_executable(evaluate src/nodes/evaluate.cpp)
add_executable(relocalisation_experiment src/nodes/relocalisation_experiment.cpp)
add_executable(calibrate_noise src/nodes/calibrate_noise.cpp)
set(EKF_SLAM_TOOL_PROGRAMS simulate evaluate relocalisation_experiment calibrate_noise)
foreach(t ${EKF_SLAM_TOOL_PROGRAMS})
  target_link_libraries(${t} ekf_slam_tools)
endforeach()
set_target_properties(${EKF_SLAM_TOOL_PROGRAMS} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS ekf_slam_tools ${EKF_SLAM_TOOL_PROGRAMS}
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
