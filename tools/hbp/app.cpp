#include "app.hpp"

#include "command_registry.hpp"

namespace hbp::cli {

std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}

std::unique_ptr<CLI::App> make_app() {
  auto app =
      std::make_unique<CLI::App>("hbp: hybrid fixed-function / processor broad-phase collision detection");
  app->require_subcommand(1);
  for (auto& setup : command_registry()) setup(*app);
  return app;
}

void remove_callbacks(CLI::App& app) {
  app.callback({});
  app.preparse_callback({});
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) remove_callbacks(*sub);
}

}  // namespace hbp::cli
