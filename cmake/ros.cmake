# The ROS shell (include/ekf_slam/ros, src/ros): message bridges, parameter server, plugin
# loading, the plugin exports, the node and the offline runner.

# Shared by the node, the offline runner and the tools: conversions, the parameter server as a
# Configuration, pluginlib as a PluginFactory, the Victoria Park bag writer.
add_library(ekf_slam_ros
  src/ros/conversions.cpp
  src/ros/extractor_loader.cpp
  src/ros/ros_parameter_source.cpp
  src/ros/ros_configuration.cpp
  src/ros/plugin_loader.cpp
  src/ros/victoria_park_bag.cpp)
target_include_directories(ekf_slam_ros PUBLIC include)
target_link_libraries(ekf_slam_ros PUBLIC ekf_slam_core ekf_slam_app ekf_slam_victoria_park
                                          ${catkin_LIBRARIES})
# pluginlib dlopen()s the plugin libraries: whatever loads them needs them built.
add_dependencies(ekf_slam_ros ${catkin_EXPORTED_TARGETS} ${PROJECT_NAME}_generate_messages_cpp
                 ekf_slam_association_plugins ekf_slam_relocalisation_plugins
                 ekf_slam_extraction_plugins)

# The plugin libraries named in association_plugins.xml, relocalisation_plugins.xml and
# extraction_plugins.xml; only pluginlib dlopen()s them.
foreach(family association relocalisation extraction)
  add_library(ekf_slam_${family}_plugins src/ros/plugins/${family}_plugins.cpp)
  target_include_directories(ekf_slam_${family}_plugins PRIVATE include)
  target_link_libraries(ekf_slam_${family}_plugins ekf_slam_core ${catkin_LIBRARIES})
endforeach()

# The node: its ROS class and markers; `rosrun ekf_slam ekf_slam`.
add_library(ekf_slam_node src/ros/node/ekf_slam_node.cpp src/ros/node/node_services.cpp
                          src/ros/node/node_diagnostics.cpp src/ros/node/markers.cpp)
target_link_libraries(ekf_slam_node PUBLIC ekf_slam_ros)
add_executable(ekf_slam_node_main src/nodes/ekf_slam_node_main.cpp)
target_link_libraries(ekf_slam_node_main ekf_slam_node)
set_target_properties(ekf_slam_node_main PROPERTIES OUTPUT_NAME ekf_slam)

# The offline runner: a bag through the same pipeline, as fast as the CPU allows (it scores
# simulated bags, so it links the test bench's scorers, not its simulator); `rosrun ekf_slam
# ekf_slam_offline`.
add_library(ekf_slam_offline_runner
  src/ros/offline/checked_bag_reader.cpp
  src/ros/offline/bag_input.cpp
  src/ros/offline/run_record.cpp
  src/ros/offline/offline_report.cpp
  src/ros/offline/offline_runner.cpp)
target_link_libraries(ekf_slam_offline_runner
  PUBLIC ekf_slam_ros ekf_slam_scoring PRIVATE nlohmann_json::nlohmann_json)
add_executable(ekf_slam_offline src/nodes/ekf_slam_offline.cpp)
target_link_libraries(ekf_slam_offline ekf_slam_offline_runner)

# Commands of the ROS side: the data set converter, the feature extractor, the replay of a
# saved association problem and the GPS reference for rviz (victoria_park.launch).
add_executable(victoria_park_to_bag src/nodes/victoria_park_to_bag.cpp)
target_link_libraries(victoria_park_to_bag ekf_slam_ros)
add_executable(detect_trees src/nodes/detect_trees.cpp)
target_link_libraries(detect_trees ekf_slam_ros)
add_executable(replay_association src/nodes/replay_association.cpp)
target_link_libraries(replay_association ekf_slam_ros)
# The GPS reference (its own library: the demo's build does not need it).
add_library(ekf_slam_gps_track src/ros/gps_track.cpp)
target_link_libraries(ekf_slam_gps_track PUBLIC ekf_slam_ros)
add_executable(gps_track src/nodes/gps_track.cpp)
target_link_libraries(gps_track ekf_slam_gps_track)

set(EKF_SLAM_ROS_PROGRAMS ekf_slam_node_main ekf_slam_offline victoria_park_to_bag detect_trees
                          replay_association gps_track)
set_target_properties(${EKF_SLAM_ROS_PROGRAMS} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${BIN_DIR})
install(TARGETS ekf_slam_ros ekf_slam_association_plugins ekf_slam_relocalisation_plugins
                ekf_slam_extraction_plugins ekf_slam_node ekf_slam_offline_runner ekf_slam_gps_track
                ${EKF_SLAM_ROS_PROGRAMS}
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(DIRECTORY include/ DESTINATION ${CATKIN_GLOBAL_INCLUDE_DESTINATION})
install(FILES association_plugins.xml relocalisation_plugins.xml extraction_plugins.xml
        DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(DIRECTORY launch rviz DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(FILES config/simulation.yaml config/robot.yaml config/victoria_park.yaml config/gps_track.yaml
        DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/config)
# Run as `python3 plot_map.py` by the offline runner, found in the package share folder.
install(FILES scripts/plot_map.py DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/scripts)
