# ROS-free estimator (Eigen only): include/ekf_slam/core, src/core.
add_library(ekf_slam_core
  # common: angles, poses, chi2, small-matrix decompositions, parameters, the sensor's region, a
  # coverage grid, assignment, a track's drawable runs
  src/core/common/chi2.cpp
  src/core/common/decompositions.cpp
  src/core/common/parameters.cpp
  src/core/common/recording_parameter_source.cpp
  src/core/common/sensor_model.cpp
  src/core/common/coverage_grid.cpp
  src/core/common/assignment_solver.cpp
  src/core/common/track_split.cpp
  # filter: observations, the EKF (full and compressed), its models, the landmarks' spatial index,
  # scans carried by the odometry
  src/core/filter/observation_model.cpp
  src/core/filter/motion_models.cpp
  src/core/filter/odometry_correction.cpp
  src/core/filter/symmetric_rank_update.cpp
  src/core/filter/ekf_slam.cpp
  src/core/filter/compressed_ekf.cpp
  src/core/filter/landmark_index.cpp
  src/core/filter/scan_window.cpp
  # feature extraction: scan filters, extractors
  src/core/feature_extraction/scan_geometry.cpp
  src/core/feature_extraction/scan_occlusion.cpp
  src/core/feature_extraction/scan_filter_chain.cpp
  src/core/feature_extraction/feature_extractor.cpp
  src/core/feature_extraction/tree_extractor.cpp
  src/core/feature_extraction/tree_feature_extractor.cpp
  src/core/feature_extraction/beacon_extractor.cpp
  # association: the interface and one file per algorithm
  src/core/association/association_context.cpp
  src/core/association/gating.cpp
  src/core/association/nn.cpp
  src/core/association/jcbb.cpp
  src/core/association/nnjcbb.cpp
  src/core/association/hungarian.cpp
  src/core/association/joint_ml.cpp
  src/core/association/rrwsc.cpp
  # DJNN: the paper's algorithm, then each extension, then the plugin that joins them
  src/core/association/djnn/tentative_set.cpp
  src/core/association/djnn/djnn_paper.cpp
  src/core/association/djnn/ambiguity_gate.cpp
  src/core/association/djnn/mover_speed.cpp
  src/core/association/djnn/static_failure_rate.cpp
  src/core/association/djnn/static_test.cpp
  src/core/association/djnn/bias_test.cpp
  src/core/association/djnn/follow_pose.cpp
  src/core/association/djnn/density_test.cpp
  src/core/association/djnn/missed_detection_profile.cpp
  src/core/association/djnn/detection_estimate.cpp
  src/core/association/djnn/landmark_spacing.cpp
  src/core/association/djnn/remembered_features.cpp
  src/core/association/djnn/closure_evidence.cpp
  src/core/association/djnn/pose_correction.cpp
  src/core/association/djnn/held_confirmation.cpp
  src/core/association/djnn/occluded_misses.cpp
  src/core/association/djnn/optimal_assignment.cpp
  src/core/association/djnn/beam_spacing_misses.cpp
  src/core/association/djnn/held_sightings.cpp
  src/core/association/djnn/unmapped_returns.cpp
  src/core/association/djnn/joint_decision.cpp
  src/core/association/djnn/djnn.cpp
  # graph matching (RRW&SC)
  src/core/graph_matching/shape_context.cpp
  src/core/graph_matching/reweighted_random_walks.cpp
  src/core/graph_matching/rrwsc_matcher.cpp
  # relocalisation: the interface, FGCBB / GCBB, RRW&SC
  src/core/relocalisation/relocaliser.cpp
  src/core/relocalisation/geometric_constraints.cpp
  src/core/relocalisation/geometric_constraint_bb.cpp
  src/core/relocalisation/fgcbb.cpp
  src/core/relocalisation/gcbb.cpp
  src/core/relocalisation/rrwsc_relocaliser.cpp
  # pipeline: a scan from input to update, lost-robot recovery, map files
  src/core/pipeline/pipeline_config.cpp
  src/core/pipeline/input_sequencer.cpp
  src/core/pipeline/motion_predictor.cpp
  src/core/pipeline/observation_builder.cpp
  src/core/pipeline/landmark_book.cpp
  src/core/pipeline/map_updater.cpp
  src/core/pipeline/delayed_sightings.cpp
  src/core/pipeline/lost_monitor.cpp
  src/core/pipeline/kidnap_onset.cpp
  src/core/pipeline/lost_scans.cpp
  src/core/pipeline/recovery.cpp
  src/core/pipeline/map_file.cpp
  src/core/pipeline/slam_pipeline.cpp
  # smoothing: the batch smoother of a finished run and its recorder (noise calibration, built on
  # them, is in ekf_slam_tools)
  src/core/smoothing/batch_smoother.cpp
  src/core/smoothing/smoothing_recorder.cpp)
target_include_directories(ekf_slam_core PUBLIC include)
target_link_libraries(ekf_slam_core PUBLIC Eigen3::Eigen)
# The rank downdate's AVX2 kernel (src/core/filter/symmetric_rank_update.cpp picks it at run time
# on CPUs that have AVX2; same result to the bit). Not with EKF_SLAM_NATIVE, whose own kernel is
# already as wide.
include(CheckCXXCompilerFlag)
check_cxx_compiler_flag(-mavx2 EKF_SLAM_COMPILER_HAS_MAVX2)
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND EKF_SLAM_COMPILER_HAS_MAVX2
   AND NOT EKF_SLAM_NATIVE)
  target_sources(ekf_slam_core PRIVATE src/core/filter/symmetric_rank_update_avx2.cpp)
  set_source_files_properties(src/core/filter/symmetric_rank_update_avx2.cpp PROPERTIES
                              COMPILE_OPTIONS -mavx2 SKIP_PRECOMPILE_HEADERS ON)
  set_source_files_properties(src/core/filter/symmetric_rank_update.cpp PROPERTIES
                              COMPILE_DEFINITIONS EKF_SLAM_AVX2_KERNEL)
endif()
