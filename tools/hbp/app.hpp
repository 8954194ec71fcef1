// SPDX-License-Identifier: MIT
#pragma once
// The `hbp` command line as a value: main() parses it, and the argument-parser
// fuzz target (fuzz/fuzz_cli.cpp) builds the same app without running it.
#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

namespace hbp::cli {

// A fresh app with every registered command (see command_registry.hpp).
// Parsing it runs the chosen command's callback.
std::unique_ptr<CLI::App> make_app();

// Callbacks taken out of an app. Commands keep their option storage alive
// through their callbacks' captures, so these must outlive any parse.
struct RemovedCallbacks {
  std::vector<std::function<void()>> callbacks;
  std::vector<std::function<void(std::size_t)>> preparse_callbacks;
};

// Takes the callbacks out of the app and all its subcommands, so that parsing
// only checks and converts the arguments. Keep the result while parsing.
[[nodiscard]] RemovedCallbacks remove_callbacks(CLI::App& app);

}  // namespace hbp::cli
