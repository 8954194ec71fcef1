// SPDX-License-Identifier: MIT
#include "hbp/cuda/cuda_engines.hpp"

#include <memory>
#include <string>

#include "cuda/cell_sweep.hpp"
#include "cuda/device_cell.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/software_engine.hpp"

namespace hbp::cuda {
namespace {

// The accelerator is a sweep: cells longer in x and the sweep's default
// cell limit, as the software sweep ("sw").
class CudaEngineBase : public CellEngine {
 public:
  std::uint32_t capacity() const override { return 0xFFFFFFFFu; }
  std::uint32_t default_cell_limit() const override { return SoftwareEngine::kDefaultSweepCellLimit; }
  float x_split_weight() const override { return 0.5f; }
};

class HostEngine final : public CudaEngineBase {
 public:
  std::string name() const override { return "cuda-host"; }
  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override {
    sweep_.run(cell, false, CellRegion::everything(), pair_limit_, out);
    return {};
  }
  CellRun find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) override {
    sweep_.run(cell, true, region, pair_limit_, out);
    return {};
  }
  std::unique_ptr<CellEngine> clone() const override {
    auto e = std::make_unique<HostEngine>();
    e->set_pair_limit(pair_limit_);
    return e;
  }

 private:
  CellSweep sweep_;
};

class DeviceEngine final : public CudaEngineBase {
 public:
  std::string name() const override { return "cuda"; }
  CellRun find_pairs(const BoxArray& cell, std::vector<Pair>& out) override {
    sweep_.sort(cell, false);
    device_.run(sweep_, CellRegion::everything(), pair_limit_, out);
    return {};
  }
  CellRun find_owned_pairs(const BoxArray& cell, const CellRegion& region, std::vector<Pair>& out) override {
    sweep_.sort(cell, true);
    device_.run(sweep_, region, pair_limit_, out);
    return {};
  }
  void find_owned_pairs_batch(const CellBatch& batch, std::vector<Pair>& out,
                              std::span<CellBatchOutcome> outcomes) override {
    device_.run_batch(batch, pair_limit_, out, outcomes);
  }
  std::unique_ptr<CellEngine> clone() const override {
    auto e = std::make_unique<DeviceEngine>();
    e->set_pair_limit(pair_limit_);
    return e;
  }

 private:
  CellSweep sweep_;
  DeviceCell device_;  // first: throws when there is no device
};

std::unique_ptr<CellEngine> make_host() { return std::make_unique<HostEngine>(); }
std::unique_ptr<CellEngine> make_device() { return std::make_unique<DeviceEngine>(); }

}  // namespace

void register_cell_engines() {
  register_cell_engine("cuda-host", &make_host,
                       "GPU accelerator kernel (a lane per box sweeping its cell, ownership fused) run on the CPU");
  register_cell_engine("cuda", &make_device, "GPU accelerator kernel on a CUDA device (needs an NVIDIA GPU)");
}

}  // namespace hbp::cuda
