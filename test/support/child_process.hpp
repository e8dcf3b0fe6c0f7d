// Starts a program as a child process for multi-process tests; stops it on destruction. Or runs
// a shell command to its end and returns what it printed.
#pragma once

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
  explicit ChildProcess(const std::vector<std::string>& argv) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], nullptr, nullptr, args.data(), environ) != 0) {
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
