// Output folders and files of the command-line tools (offline runner, evaluate), with errors
// that name the path.
#pragma once

#include <fstream>
#include <string>

namespace ekf_slam {

/// Creates `dir` and its parents (like mkdir -p). Throws std::runtime_error naming the folder.
void makeDirectory(const std::string& dir);
/// Opens `path` for writing, with 10 significant digits. Throws std::runtime_error naming it.
std::ofstream openOutput(const std::string& path);

}  // namespace ekf_slam
