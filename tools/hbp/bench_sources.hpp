// SPDX-License-Identifier: MIT
#pragma once
// Where `hbp bench` gets its frames: the paper's scenario (variant v = seed
// v, boxes generated once per frame and fed to every system) or a recorded
// scene file (native or Broadmark), read frame by frame.
#include <cstdint>
#include <memory>
#include <string>

#include "bench_runner.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"

namespace hbp::cli {

// A generated scene (src/scene/scenario.cpp) of any kind: the paper's
// uniform scene, clustered, flat, huge, degenerate.
class PaperFrames final : public FrameSource {
 public:
  explicit PaperFrames(std::uint32_t n, ScenarioKind kind = ScenarioKind::Paper) : n_(n), kind_(kind) {}
  std::uint32_t object_count() const override { return n_; }
  void begin_variant(std::uint32_t variant, BoxArray& first) override;
  void next(BoxArray& boxes) override;

 private:
  std::uint32_t n_;
  ScenarioKind kind_;
  std::unique_ptr<Scenario> scenario_;
};

class SceneFrames final : public FrameSource {
 public:
  explicit SceneFrames(const std::string& path);
  std::uint32_t object_count() const override { return reader_.info().object_count; }
  // Frames after the setup frame that the file can still give.
  std::uint32_t frames_after_first() const { return reader_.info().frame_count - 1; }
  const SceneInfo& info() const { return reader_.info(); }
  // Every variant replays the file from frame 0.
  void begin_variant(std::uint32_t variant, BoxArray& first) override;
  void next(BoxArray& boxes) override;

 private:
  SceneReader reader_;
  std::uint32_t frame_ = 0;
};

}  // namespace hbp::cli
