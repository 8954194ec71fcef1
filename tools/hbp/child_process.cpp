// SPDX-License-Identifier: MIT
#include "child_process.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "hbp/error.hpp"

extern "C" char** environ;

namespace hbp::cli {

std::string shell_quoted(const std::vector<std::string>& argv) {
  std::string line;
  for (const std::string& arg : argv) {
    if (!line.empty()) line += ' ';
    const bool plain = !arg.empty() && arg.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                                             "0123456789_@%+=:,./-") == std::string::npos;
    if (plain) {
      line += arg;
      continue;
    }
    line += '\'';
    for (char c : arg) line += c == '\'' ? std::string("'\\''") : std::string(1, c);
    line += '\'';
  }
  return line;
}

void run_program(const std::vector<std::string>& argv) {
  if (argv.empty()) throw InvalidInput("run_program: no program given");
  std::vector<std::string> args = argv;  // posix_spawnp takes char* const[]
  std::vector<char*> pointers;
  for (std::string& a : args) pointers.push_back(a.data());
  pointers.push_back(nullptr);
  pid_t pid = 0;
  const std::string command = shell_quoted(argv);  // last in every message: nothing after it to misread
  // glibc's posix_spawnp reports a program it cannot find or execute here;
  // exit status 127 is how a shell script reports one of its own.
  const int spawn_error = posix_spawnp(&pid, args[0].c_str(), nullptr, nullptr, pointers.data(), environ);
  if (spawn_error != 0)
    throw Error("cannot start '" + argv[0] + "': " + std::strerror(spawn_error) + "; command: " + command);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR)
      throw Error(std::string("cannot wait for the child: ") + std::strerror(errno) + "; command: " + command);
  }
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    if (code == 0) return;
    throw Error("exit status " + std::to_string(code) + (code == 127 ? " (a program was not found)" : "") +
                " from: " + command);
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = sigabbrev_np(sig);
    throw Error("killed by signal " + std::to_string(sig) + (name ? std::string(" (SIG") + name + ")" : std::string()) +
                ": " + command);
  }
  throw Error("ended abnormally (wait status " + std::to_string(status) + "): " + command);
}

}  // namespace hbp::cli
