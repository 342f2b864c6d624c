# ROS-free assembly (include/ekf_slam/app, src/app): the node's settings, configurations (YAML),
# the one pipeline builder of every entry point, and the package's file formats.
add_library(ekf_slam_app
  src/app/node_config.cpp
  src/app/pipeline_builder.cpp
  src/app/yaml_parameter_source.cpp
  src/app/yaml_configuration.cpp
  src/app/scan_filter_yaml.cpp
  src/app/association_problem.cpp
  src/app/output_files.cpp
  src/app/command_line.cpp)
target_include_directories(ekf_slam_app PUBLIC include)
target_link_libraries(ekf_slam_app PUBLIC ekf_slam_core yaml-cpp
  PRIVATE nlohmann_json::nlohmann_json)

# Victoria Park reader (ROS-free; libmatio): include/ekf_slam/data, src/data.
add_library(ekf_slam_victoria_park src/data/victoria_park.cpp)
target_include_directories(ekf_slam_victoria_park PUBLIC include)
target_link_libraries(ekf_slam_victoria_park PUBLIC PkgConfig::MATIO)

install(TARGETS ekf_slam_core ekf_slam_app ekf_slam_victoria_park
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION})
