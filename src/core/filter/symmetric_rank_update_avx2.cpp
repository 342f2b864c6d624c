// The rank downdate's kernel with 4-lane AVX vectors: this file alone is compiled with -mavx2
// (cmake/core.cmake; x86-64 builds without EKF_SLAM_NATIVE), and symmetric_rank_update.cpp
// calls it only on CPUs that report AVX2. No -mfma: its result equals the baseline's to the bit.
#define EKF_SLAM_KERNEL_LANES 4
#define EKF_SLAM_KERNEL_NAMESPACE avx2_kernel
#include "rank_downdate_kernel.h"
