// SPDX-License-Identifier: MIT
#include <map>
#include <mutex>

#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp/software_engine.hpp"

// The engine registry. The core's own engines are entered on first use;
// engines of the rooms above (hardware models, RTL) are entered by their
// register functions: the registry is how an upper layer plugs in below,
// so this file includes nothing of theirs.
namespace hbp {

namespace {

struct Entry {
  CellEngineFactory factory;
  std::string description;
  bool builtin;
};

std::unique_ptr<CellEngine> make_sw() { return std::make_unique<SoftwareEngine>(SoftwareEngine::Kernel::Sweep); }
std::unique_ptr<CellEngine> make_sw_allpairs() {
  return std::make_unique<SoftwareEngine>(SoftwareEngine::Kernel::AllPairs);
}
std::unique_ptr<CellEngine> make_brute() { return std::make_unique<BruteForceEngine>(); }

struct Registry {
  std::mutex mutex;
  std::map<std::string, Entry> engines = {
      {"sw", {make_sw, "software engine, SIMD sweep over the min-x order (default)", true}},
      {"sw-allpairs", {make_sw_allpairs, "software engine, SIMD all-pairs", true}},
      {"brute", {make_brute, "scalar all-pairs (the reference)", true}},
  };
};

Registry& registry() {
  static Registry r;
  return r;
}

std::string known_names(const Registry& r) {
  std::string known;
  for (const auto& [n, e] : r.engines) known += (known.empty() ? "" : ", ") + n;
  return known;
}

}  // namespace

void register_cell_engine(const std::string& name, CellEngineFactory factory, const std::string& description) {
  if (name.empty()) throw InvalidInput("register_cell_engine: empty engine name");
  if (factory == nullptr) throw InvalidInput("register_cell_engine: null factory for engine '" + name + "'");
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  auto [it, inserted] = r.engines.try_emplace(name, Entry{factory, description, false});
  if (inserted || (!it->second.builtin && it->second.factory == factory)) return;
  throw InvalidInput("register_cell_engine: engine name '" + name + "' is already taken by " +
                     (it->second.builtin ? "a built-in engine" : "another registered engine") +
                     " (choose another name)");
}

std::vector<std::string> cell_engine_names() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& [name, e] : r.engines) names.push_back(name);
  return names;
}

std::string cell_engine_description(const std::string& name) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  if (auto it = r.engines.find(name); it != r.engines.end()) return it->second.description;
  throw InvalidInput("unknown engine '" + name + "' (known: " + known_names(r) + ")");
}

std::unique_ptr<CellEngine> make_cell_engine(const std::string& name) {
  CellEngineFactory factory = nullptr;
  {
    Registry& r = registry();
    std::lock_guard lock(r.mutex);
    auto it = r.engines.find(name);
    if (it == r.engines.end()) throw InvalidInput("unknown engine '" + name + "' (known: " + known_names(r) + ")");
    factory = it->second.factory;
  }
  return factory();
}

}  // namespace hbp
