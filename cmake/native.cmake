# -DEKF_SLAM_NATIVE=ON: compile for this machine's vector units (-march=native: AVX2 and FMA on
# most x86-64 today). Off by default so that binaries stay portable (docs/benchmarks_vp.md has
# the update's speed both ways). Included before any target so that every one gets it.
# The name the issue and docs give; catkin_lint would want the project name in lower case.
#catkin_lint: ignore_once global_var_collision
option(EKF_SLAM_NATIVE "Compile with -march=native (not portable to other CPUs)" OFF)
if(EKF_SLAM_NATIVE)
  add_compile_options(-march=native)
endif()
