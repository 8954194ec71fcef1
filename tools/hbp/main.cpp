// SPDX-License-Identifier: MIT
// hbp: the hybrid-broadphase command-line tool.
#include <cstdio>
#include <exception>

#include "app.hpp"
#include "hbp/error.hpp"
#include "hbp/software_engine.hpp"
#ifdef HBP_HAVE_RTL
#include "hbp/rtl/rtl_engines.hpp"
#endif
#ifdef HBP_HAVE_CUDA
#include "hbp/cuda/cuda_engines.hpp"
#endif

int main(int argc, char** argv) {
#ifdef HBP_HAVE_RTL
  hbp::rtl::register_rtl_engines();  // rtl-ae, rtl-mo: the Verilated RTL as cell engines
#endif
#ifdef HBP_HAVE_CUDA
  hbp::cuda::register_cell_engines();  // cuda, cuda-host: the GPU accelerator kernel as cell engines
#endif
  const auto app_ptr = hbp::cli::make_app();
  CLI::App& app = *app_ptr;
  try {
    // A bad HBP_SIMD is an error for every command, before any work (the
    // value is read once; the kernels would otherwise fail mid-frame).
    (void)hbp::SoftwareEngine::isa();
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
