// SPDX-License-Identifier: MIT
// hbp: the hybrid-broadphase command-line tool.
//
// Exit status (docs/cli.md):
//   0  success (also --help and --version)
//   1  the command ran and failed: an invalid value, a file that cannot be
//      read or written, a failed check (a bench mismatch, hw table --check)
//   2  usage: the command line does not parse (unknown command or option,
//      a missing or malformed argument, a value outside its range)
#include <cstdio>
#include <exception>
#include <string>

#include "app.hpp"
#include "hbp/error.hpp"
#include "hbp/software_engine.hpp"
#ifdef HBP_HAVE_RTL
#include "hbp/rtl/rtl_engines.hpp"
#endif
#ifdef HBP_HAVE_CUDA
#include "hbp/cuda/cuda_engines.hpp"
#endif

namespace {
constexpr int kExitUsage = 2;
}  // namespace

int main(int argc, char** argv) {
#ifdef HBP_HAVE_RTL
  hbp::rtl::register_rtl_engines();  // rtl-ae, rtl-mo: the Verilated RTL as cell engines
#endif
#ifdef HBP_HAVE_CUDA
  hbp::cuda::register_cell_engines();  // cuda, cuda-host: the GPU accelerator kernel as cell engines
#endif
  const auto app_ptr = hbp::cli::make_app();
  CLI::App& app = *app_ptr;
  // CLI11 reports an unknown command as "A subcommand is required": name it
  // and the commands there are.
  if (argc > 1 && argv[1][0] != '-') {
    const auto commands = app.get_subcommands([](CLI::App*) { return true; });
    bool known = false;
    std::string names;
    for (const CLI::App* c : commands) {
      known |= c->check_name(argv[1]);
      names += (names.empty() ? "" : ", ") + c->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "hbp: unknown command '%s' (commands: %s)\nRun with --help for more information.\n",
                   argv[1], names.c_str());
      return kExitUsage;
    }
  }
  try {
    // A bad HBP_SIMD is an error for every command, before any work (the
    // value is read once; the kernels would otherwise fail mid-frame).
    (void)hbp::SoftwareEngine::isa();
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return app.exit(e);  // a command's own failure status (1)
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);  // prints the help, the version or the message
    return status == 0 ? 0 : kExitUsage;
  } catch (const hbp::Error& e) {
    std::fprintf(stderr, "hbp: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hbp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
