// A program's arguments, read one flag at a time with the same answers in every program of the
// package (ekf_slam_offline, victoria_park_to_bag and the tools): -h / --help, "unknown argument
// 'X'", "X needs a value". Each program keeps its own flags and value checks.
//
//   CommandLine args(argv_as_strings);
//   while (args.next()) {
//     if (args.is("--no-progress")) o->progress = false;
//     else if (args.is("--bag")) args.value(&o->bag_path);
//     else args.unknown();
//   }
//   if (!args.finish(&help, &error)) return false;   // error() in `error`
//   if (help) ... print the usage ...
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace ekf_slam {

class CommandLine {
 public:
  explicit CommandLine(std::vector<std::string> args) : args_(std::move(args)) {}

  /// Moves to the next argument. False at the end, at -h / --help, and after an error.
  bool next();
  /// Whether the current flag is `flag` (also after its value was taken).
  bool is(const char* flag) const { return args_[flag_] == flag; }
  /// The current flag.
  const std::string& flag() const { return args_[flag_]; }
  /// Takes the argument after the flag into `out`; false, with "FLAG needs a value", when none.
  bool value(std::string* out);
  /// Records an error (the first one counts) and stops next(); returns false.
  bool fail(const std::string& message);
  /// fail("unknown argument 'FLAG'").
  bool unknown() { return fail("unknown argument '" + flag() + "'"); }

  /// After the loop: *help = help(), *error = error(); false after an error.
  bool finish(bool* help, std::string* error) const;

  bool help() const { return help_; }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

 private:
  std::vector<std::string> args_;
  std::size_t at_ = 0;    // the last argument read
  std::size_t flag_ = 0;  // the current flag
  bool started_ = false, help_ = false;
  std::string error_;
};

}  // namespace ekf_slam
