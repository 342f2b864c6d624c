#include "ekf_slam/app/command_line.h"

namespace ekf_slam {

bool CommandLine::next() {
  if (!ok() || help_) return false;
  if (started_) ++at_;
  started_ = true;
  if (at_ >= args_.size()) return false;
  flag_ = at_;
  if (args_[at_] == "-h" || args_[at_] == "--help") {
    help_ = true;
    return false;
  }
  return true;
}

bool CommandLine::value(std::string* out) {
  if (at_ + 1 >= args_.size()) return fail(flag() + " needs a value");
  *out = args_[++at_];
  return true;
}

bool CommandLine::fail(const std::string& message) {
  if (ok()) error_ = message;
  return false;
}

bool CommandLine::finish(bool* help, std::string* error) const {
  *help = help_;
  if (ok()) return true;
  *error = error_;
  return false;
}

}  // namespace ekf_slam
