// Starts a program as a child process for multi-process tests; stops it on destruction. Or runs
// a shell command to its end and returns what it printed.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <future>
#include <string>
#include <vector>

extern char** environ;

namespace ptz::test {

class ChildProcess {
 public:
  // stderr_path: the child's stderr goes to this file (empty: the test's stderr).
  explicit ChildProcess(const std::vector<std::string>& argv, const std::string& stderr_path = "") {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!stderr_path.empty()) {
      posix_spawn_file_actions_addopen(&actions, 2, stderr_path.c_str(),
                                       O_WRONLY | O_CREAT | O_TRUNC, 0644);
    }
    const int spawned = posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) {
      pid_ = -1;
      return;
    }
    // A waiter thread blocks in waitpid, so wait() can use a timeout.
    exit_code_ = std::async(std::launch::async, [pid = pid_] {
      int status = 0;
      if (waitpid(pid, &status, 0) != pid) return -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    });
  }
  ~ChildProcess() { stop(); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }
  // Whether it still runs (it has not exited by itself).
  bool running() { return wait(std::chrono::milliseconds(0)) < 0; }

  // Waits for the child to exit by itself; returns its exit code, or -1 on timeout.
  int wait(std::chrono::milliseconds timeout) {
    if (!exit_code_.valid()) return code_;
    if (exit_code_.wait_for(timeout) != std::future_status::ready) return -1;
    code_ = exit_code_.get();
    return code_;
  }

  // SIGTERM, then SIGKILL if it does not exit within two seconds. Returns the exit code.
  int stop() {
    if (!exit_code_.valid()) return code_;
    kill(pid_, SIGTERM);
    int code = wait(std::chrono::milliseconds(2000));
    if (code < 0) {
      kill(pid_, SIGKILL);
      code = wait(std::chrono::milliseconds(2000));
    }
    return code;
  }

 private:
  pid_t pid_ = -1;
  int code_ = -1;
  std::future<int> exit_code_;
};

// What `command` (through sh) printed on stdout, once it has ended.
inline std::string runShell(const std::string& command) {
  std::string out;
  FILE* f = popen(command.c_str(), "r");
  char buf[512];
  while (f && std::fgets(buf, sizeof buf, f)) out += buf;
  if (f) pclose(f);
  return out;
}

}  // namespace ptz::test
