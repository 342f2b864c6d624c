// `rosbag play --clock` as a child process of a rostest.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace test_files {

// `rosbag play -q --clock -d 1 -r RATE BAG` in its own process group (-d: the subscribers
// connect before the first message).
class RosbagPlay {
 public:
  RosbagPlay(const std::string& bag, const std::string& rate) {
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      const char* path = std::getenv("PATH");
      setenv("PATH", (std::string("/usr/bin:") + (path ? path : "")).c_str(), 1);
      execlp("rosbag", "rosbag", "play", "-q", "--clock", "-d", "1", "-r", rate.c_str(),
             bag.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~RosbagPlay() {
    if (pid_ <= 0) return;
    kill(-pid_, SIGINT);
    for (int i = 0; i < 50; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
      usleep(100000);
    }
    kill(-pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  bool started() const { return pid_ > 0; }
  /// True once it has exited (status in *code).
  bool finished(int* code) {
    if (pid_ <= 0) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
    *code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    pid_ = -1;
    return true;
  }

 private:
  pid_t pid_ = -1;
};

}  // namespace test_files
