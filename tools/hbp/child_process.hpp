// SPDX-License-Identifier: MIT
#pragma once
// Running another program from `hbp` without a shell: the arguments go to
// the child as an argument vector, so paths with spaces, quotes or `$` reach
// it unchanged (nothing to quote, nothing to inject).
#include <string>
#include <vector>

namespace hbp::cli {

// Starts argv[0] (searched on PATH like a shell would) with argv, inheriting
// stdin/stdout/stderr, and waits for it. Returns when it exits with status 0;
// otherwise throws hbp::Error saying what went wrong (could not start, e.g.
// not found; exit status; the signal that ended it), then the command.
void run_program(const std::vector<std::string>& argv);

// The command as a user would type it in a POSIX shell (arguments with
// anything but [A-Za-z0-9_@%+=:,./-] single-quoted): for messages and logs
// only, never executed.
std::string shell_quoted(const std::vector<std::string>& argv);

}  // namespace hbp::cli
