// SPDX-License-Identifier: MIT
#include "app.hpp"

#include <string>
#include <utility>

#include "command_registry.hpp"
#include "hbp/hw/hw_cell_engines.hpp"

namespace hbp::cli {

std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}

std::unique_ptr<CLI::App> make_app() {
  hbp::hw::register_cell_engines();  // ae, mo, ae-sim, mo-sim: the hardware models as cell engines
  auto app =
      std::make_unique<CLI::App>("hbp: hybrid fixed-function / processor broad-phase collision detection");
  app->require_subcommand(1);
#ifdef HBP_VERSION
  app->set_version_flag("--version", std::string("hbp ") + HBP_VERSION, "Print the version and exit");
#endif
  for (auto& setup : command_registry()) setup(*app);
  return app;
}

namespace {

// CLI::App has no getters for its callbacks; pointers to its protected
// members, formed in a derived class, reach them.
struct CallbackMembers : CLI::App {
  static constexpr auto final_callback = &CallbackMembers::final_callback_;
  static constexpr auto complete_callback = &CallbackMembers::parse_complete_callback_;
  static constexpr auto preparse_callback = &CallbackMembers::pre_parse_callback_;
};

void take_callbacks(CLI::App& app, RemovedCallbacks& out) {
  for (auto member : {CallbackMembers::final_callback, CallbackMembers::complete_callback}) {
    if (app.*member) out.callbacks.push_back(std::exchange(app.*member, nullptr));
  }
  if (app.*CallbackMembers::preparse_callback)
    out.preparse_callbacks.push_back(std::exchange(app.*CallbackMembers::preparse_callback, nullptr));
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) take_callbacks(*sub, out);
}

}  // namespace

RemovedCallbacks remove_callbacks(CLI::App& app) {
  RemovedCallbacks removed;
  take_callbacks(app, removed);
  return removed;
}

}  // namespace hbp::cli
