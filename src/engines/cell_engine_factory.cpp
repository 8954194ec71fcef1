#include <map>
#include <mutex>

#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp/software_engine.hpp"
#if __has_include("hbp/hw/hw_cell_engines.hpp")
#include "hbp/hw/hw_cell_engines.hpp"
#define HBP_HAVE_HW_MODELS 1
#endif

namespace hbp {

namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, CellEngineFactory> factories;
};

Registry& registry() {
  static Registry r;
  return r;
}

std::unique_ptr<CellEngine> make_sw() { return std::make_unique<SoftwareEngine>(SoftwareEngine::Kernel::Sweep); }
std::unique_ptr<CellEngine> make_sw_allpairs() {
  return std::make_unique<SoftwareEngine>(SoftwareEngine::Kernel::AllPairs);
}
std::unique_ptr<CellEngine> make_brute() { return std::make_unique<BruteForceEngine>(); }
#ifdef HBP_HAVE_HW_MODELS
std::unique_ptr<CellEngine> make_ae() { return hw::make_area_efficient_engine({}, false); }
std::unique_ptr<CellEngine> make_mo() { return hw::make_many_object_engine({}, false); }
std::unique_ptr<CellEngine> make_ae_sim() { return hw::make_area_efficient_engine({}, true); }
std::unique_ptr<CellEngine> make_mo_sim() { return hw::make_many_object_engine({}, true); }
#endif

const std::map<std::string, CellEngineFactory>& builtin() {
  static const std::map<std::string, CellEngineFactory> engines = {
      {"sw", make_sw},
      {"sw-allpairs", make_sw_allpairs},
      {"brute", make_brute},
#ifdef HBP_HAVE_HW_MODELS
      {"ae", make_ae},
      {"mo", make_mo},
      {"ae-sim", make_ae_sim},
      {"mo-sim", make_mo_sim},
#endif
  };
  return engines;
}

}  // namespace

void register_cell_engine(const std::string& name, CellEngineFactory factory) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.factories[name] = factory;
}

std::vector<std::string> cell_engine_names() {
  std::vector<std::string> names;
  for (const auto& [name, f] : builtin()) names.push_back(name);
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (const auto& [name, f] : r.factories) names.push_back(name);
  return names;
}

std::unique_ptr<CellEngine> make_cell_engine(const std::string& name) {
  if (auto it = builtin().find(name); it != builtin().end()) return it->second();
  {
    Registry& r = registry();
    std::lock_guard lock(r.mutex);
    if (auto it = r.factories.find(name); it != r.factories.end()) return it->second();
  }
  std::string known;
  for (const auto& n : cell_engine_names()) known += (known.empty() ? "" : ", ") + n;
  throw InvalidInput("unknown engine '" + name + "' (known: " + known + ")");
}

}  // namespace hbp
