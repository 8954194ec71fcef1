#pragma once
// The `hbp` command line as a value: main() parses it, and the argument-parser
// fuzz target (fuzz/fuzz_cli.cpp) builds the same app without running it.
#include <CLI/CLI.hpp>
#include <memory>

namespace hbp::cli {

// A fresh app with every registered command (see command_registry.hpp).
// Parsing it runs the chosen command's callback.
std::unique_ptr<CLI::App> make_app();

// Empties the callbacks of the app and all its subcommands, so that parsing
// only checks and converts the arguments.
void remove_callbacks(CLI::App& app);

}  // namespace hbp::cli
