// SPDX-License-Identifier: MIT
#include "bench_machine.hpp"

#include <sys/utsname.h>

#include <fstream>
#include <string>
#include <thread>

#ifdef HBP_HAVE_BASELINES
#include "hbp/baselines/baseline.hpp"
#endif
#if __has_include("hbp/software_engine.hpp")
#include "hbp/software_engine.hpp"
#define HBP_BENCH_HAVE_ISA 1
#endif

namespace hbp::cli {
namespace {

// First value of "key : value" lines in a /proc file.
std::string proc_field(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string v = line.substr(colon + 1);
    const auto b = v.find_first_not_of(" \t");
    return b == std::string::npos ? "" : v.substr(b);
  }
  return "unknown";
}

std::string first_line(const char* path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line.empty() ? "unknown" : line;
}

std::string compiler() {
#if defined(__clang__)
  return std::string("Clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("GCC ") + __VERSION__;
#else
  return "unknown";
#endif
}

// Build flags as the compiler saw them (what the preprocessor can tell).
std::string build_flags() {
  std::string f;
#ifdef __OPTIMIZE__
  f += "optimised (-O2 or higher)";
#else
  f += "not optimised (-O0: timings meaningless)";
#endif
#ifdef NDEBUG
  f += ", NDEBUG";
#else
  f += ", assertions on";
#endif
#if defined(__AVX512F__)
  f += ", AVX-512 baked in";
#elif defined(__AVX2__)
  f += ", AVX2 baked in";
#else
  f += ", baseline x86-64 (no -march=native; SIMD kernels chosen at run time)";
#endif
#if defined(__SANITIZE_ADDRESS__)
  f += ", AddressSanitizer (timings meaningless)";
#endif
  return f;
}

}  // namespace

MachineDescription describe_machine() {
  MachineDescription m;
  m.emplace_back("cpu", proc_field("/proc/cpuinfo", "model name"));
  m.emplace_back("cores", std::to_string(std::thread::hardware_concurrency()));
  m.emplace_back("memory", proc_field("/proc/meminfo", "MemTotal"));
  utsname u{};
  if (uname(&u) == 0) m.emplace_back("os", std::string(u.sysname) + " " + u.release + " " + u.machine);
  m.emplace_back("hypervisor", proc_field("/proc/cpuinfo", "flags").find("hypervisor") != std::string::npos
                                   ? "yes (virtual machine)"
                                   : "no");
  m.emplace_back("load average at start", read_load_average());
  m.emplace_back("compiler", compiler());
  m.emplace_back("build", build_flags());
#ifdef HBP_BENCH_HAVE_ISA
  m.emplace_back("software engine ISA", SoftwareEngine::isa());
#endif
#ifdef HBP_HAVE_BASELINES
  for (const auto& [lib, version] : baselines::baseline_library_versions()) m.emplace_back(lib, version);
#endif
  return m;
}

std::string read_load_average() { return first_line("/proc/loadavg"); }

std::string machine_summary(const MachineDescription& m) {
  auto get = [&](const std::string& k) -> std::string {
    for (const auto& [key, v] : m)
      if (key == k) return v;
    return "?";
  };
  return get("cpu") + ", " + get("cores") + " cores, " + get("memory") + ", " + get("compiler");
}

}  // namespace hbp::cli
