// SPDX-License-Identifier: MIT
#include "bench_sources.hpp"

#include "bench_systems.hpp"

#include "hbp/error.hpp"

namespace hbp::cli {

void PaperFrames::begin_variant(std::uint32_t variant, BoxArray& first) {
  ScenarioParams p;  // the paper's scenario (section 5) or another kind, default parameters
  p.kind = kind_;
  p.n = n_;
  p.seed = variant;
  scenario_ = std::make_unique<Scenario>(p);
  current_bench_shapes() = &scenario_->shapes();
  scenario_->compute_boxes(first);
}

void PaperFrames::next(BoxArray& boxes) {
  scenario_->step();
  scenario_->compute_boxes(boxes);
}

SceneFrames::SceneFrames(const std::string& path) : reader_(path) {
  if (reader_.info().frame_count < 2)
    throw InvalidInput(path + ": hbp bench needs at least 2 frames (one to set up, one to time), the file has " +
                       std::to_string(reader_.info().frame_count));
}

void SceneFrames::begin_variant(std::uint32_t, BoxArray& first) {
  current_bench_shapes() = nullptr;
  frame_ = 0;
  reader_.read_frame(0, first);
}

void SceneFrames::next(BoxArray& boxes) {
  if (frame_ + 1 >= reader_.info().frame_count)
    throw InvalidInput(reader_.path() + ": asked for frame " + std::to_string(frame_ + 1) + " of " +
                       std::to_string(reader_.info().frame_count));
  reader_.read_frame(++frame_, boxes);
}

}  // namespace hbp::cli
