// hbp: the hybrid-broadphase command-line tool.
#include <cstdio>
#include <exception>

#include "command_registry.hpp"
#include "hbp/error.hpp"

namespace hbp::cli {
std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}
}  // namespace hbp::cli

int main(int argc, char** argv) {
  CLI::App app{"hbp: hybrid fixed-function / processor broad-phase collision detection"};
  app.require_subcommand(1);
  for (auto& setup : hbp::cli::command_registry()) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const hbp::Error& e) {
    std::fprintf(stderr, "hbp: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hbp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
