// `roslaunch` as a child process of a rostest, for the tests that start a launch file.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace test_files {

// `roslaunch` as a child in its own process group, its output in a log file.
class Roslaunch {
 public:
  Roslaunch(const std::vector<std::string>& args, const std::string& log) {
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      // Debian's python must come first (ROS_ON_DEBIAN.md, pitfall 1).
      const char* path = std::getenv("PATH");
      setenv("PATH", (std::string("/usr/bin:") + (path ? path : "")).c_str(), 1);
      if (FILE* f = std::freopen(log.c_str(), "w", stdout)) dup2(fileno(f), STDERR_FILENO);
      std::vector<char*> argv;
      static std::string program = "roslaunch";
      argv.push_back(program.data());
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execvp("roslaunch", argv.data());
      _exit(127);
    }
  }
  ~Roslaunch() {
    if (pid_ <= 0) return;
    // SIGINT lets roslaunch stop its nodes; SIGKILL the group if it does not.
    kill(-pid_, SIGINT);
    for (int i = 0; i < 150; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
      usleep(100000);
    }
    kill(-pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  bool started() const { return pid_ > 0; }
  /// True when it has exited already (it should run until we stop it).
  bool exited() {
    if (pid_ <= 0) return true;
    if (waitpid(pid_, nullptr, WNOHANG) != pid_) return false;
    pid_ = -1;
    return true;
  }

 private:
  pid_t pid_ = -1;
};

}  // namespace test_files
