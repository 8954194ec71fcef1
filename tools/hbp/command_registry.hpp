// SPDX-License-Identifier: MIT
#pragma once
// Each `hbp` command lives in its own file and registers itself here, so a
// new command never edits main.cpp.
#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace hbp::cli {

using CommandSetup = std::function<void(CLI::App& app)>;

std::vector<CommandSetup>& command_registry();

struct RegisterCommand {
  explicit RegisterCommand(CommandSetup setup) { command_registry().push_back(std::move(setup)); }
};

}  // namespace hbp::cli
