#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

const char* toString(RelocalisationStatus s) {
  switch (s) {
    case RelocalisationStatus::kFound:
      return "found";
    case RelocalisationStatus::kNotFound:
      return "not_found";
    case RelocalisationStatus::kAmbiguous:
      return "ambiguous";
  }
  return "unknown";
}

}  // namespace ekf_slam
