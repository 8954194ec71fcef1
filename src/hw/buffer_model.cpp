// SPDX-License-Identifier: MIT
#include "hbp/hw/buffer_model.hpp"

#include "hbp/hw/buffer_input_checks.hpp"

namespace hbp::hw {

BufferModel::BufferModel(Design design, const ModelConfig& cfg) : design_(design), cfg_(cfg) {
  validate(cfg_);
  buffer_.configure(cfg_.m, cfg_.depth);
}

std::uint32_t BufferModel::pipeline_depth() const { return hw::pipeline_depth(design_, cfg_); }

Resources BufferModel::resources() const { return hw::resources(design_, cfg_); }

CycleBreakdown BufferModel::analytic_cycles(std::uint64_t n) const {
  return hw::analytic_cycles(design_, n, cfg_);
}

void BufferModel::check_input(const BoxArray& boxes) const { check_buffer_input(design_, cfg_, boxes); }

}  // namespace hbp::hw
