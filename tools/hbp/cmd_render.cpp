// SPDX-License-Identifier: MIT
// hbp render: ray-traced images of a scene through the two-level hierarchy
// the collision partition shares (paper section 3.2, Fig. 3).
//
//   hbp render --scene paper --n 400 --frame 0 --width 800 --height 800 --out fig.png
//   hbp render --n 400 --highlight-collisions --out collisions.png
//   hbp render --n 400 --video frames/ --frames 120
#include <tbb/global_control.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command_registry.hpp"
#include "option_checks.hpp"
#include "hbp/error.hpp"
#include "hbp/raytrace/colliding_objects.hpp"
#include "hbp/raytrace/png_writer.hpp"
#include "hbp/raytrace/renderer.hpp"
#include "hbp/scenario.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp::cli {
namespace {

struct RenderArgs {
  std::string scene = "paper";
  std::uint32_t n = 400;
  std::uint64_t seed = 0;
  std::uint32_t frame = 0;
  std::uint32_t width = 800, height = 800, samples = 1;
  std::string out;
  std::string video;
  std::uint32_t frames = 60;
  bool highlight = false;
  bool no_shadows = false;
  std::uint32_t cell_limit = 1024;
  unsigned threads = 0;
};

// Renders the scenario's current state to `path` and prints one line about it.
void render_one(const RenderArgs& a, const Scenario& scenario, const TwoLevelHierarchy& h,
                const std::vector<ShapeGeometry>& geometry, const std::string& path) {
  std::optional<CollidingObjects> collisions;
  if (a.highlight) collisions = colliding_objects(h, scenario.shapes());
  RenderOptions o;
  o.width = a.width;
  o.height = a.height;
  o.samples = a.samples;
  o.shadows = !a.no_shadows;
  if (collisions) o.highlight = collisions->flags;
  RenderStats rs;
  const Image img = render(h, geometry, scenario.world_bounds(), o, &rs);
  write_png(path, img.width, img.height, img.rgb);
  const HierarchyStats& s = h.stats();
  std::printf("%s: frame %u, %u cells (kept %u, edited %u, rebuilt %u), hierarchy %.2f ms, render %.1f ms, "
              "%.2f Mrays/s (%llu primary, %llu shadow)",
              path.c_str(), scenario.frame(), s.cells, s.refitted, s.edited, s.rebuilt, s.total_ms, rs.ms,
              static_cast<double>(rs.primary_rays + rs.shadow_rays) / (rs.ms * 1e3),
              static_cast<unsigned long long>(rs.primary_rays), static_cast<unsigned long long>(rs.shadow_rays));
  if (collisions) {
    std::uint64_t objects = 0;
    for (std::uint8_t f : collisions->flags) objects += f;
    std::printf(", %llu colliding pairs (%llu objects)", static_cast<unsigned long long>(collisions->colliding_pairs),
                static_cast<unsigned long long>(objects));
  }
  std::printf("\n");
}

// Before any rendering: the directory of --out must exist and be writable.
void check_writable(const std::string& file) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(file).parent_path().empty() ? fs::path(".") : fs::path(file).parent_path();
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (!fs::exists(st)) throw FileError("--out '" + file + "': cannot write it: directory '" + dir.string() + "' does not exist");
  if (!fs::is_directory(st))
    throw FileError("--out '" + file + "': cannot write it: '" + dir.string() + "' is not a directory");
  if (::access(dir.c_str(), W_OK) != 0)
    throw FileError("--out '" + file + "': cannot write it: directory '" + dir.string() + "': " + std::strerror(errno));
  if (fs::is_directory(fs::status(file, ec))) throw FileError("--out '" + file + "': cannot write it: it is a directory");
}

void run(const RenderArgs& a) {
  if (a.out.empty() && a.video.empty()) throw InvalidInput("render: give --out FILE.png or --video DIR");
  if (!a.out.empty()) check_writable(a.out);
  std::unique_ptr<tbb::global_control> threads;
  if (a.threads) threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  ScenarioParams p;
  p.kind = parse_scenario_kind(a.scene);
  p.n = a.n;
  p.seed = a.seed;
  Scenario scenario(p);
  TwoLevelHierarchy h({.cell_limit = a.cell_limit});
  BoxArray boxes;
  std::vector<ShapeGeometry> geometry;
  auto advance_to = [&](std::uint32_t frame) {
    // The hierarchy is maintained every frame, as in the running simulation.
    while (true) {
      scenario.compute_boxes(boxes);
      h.update(boxes);
      if (scenario.frame() >= frame) break;
      scenario.step();
    }
    prepare_shapes(scenario.shapes(), geometry);
  };
  if (!a.out.empty()) {
    advance_to(a.frame);
    render_one(a, scenario, h, geometry, a.out);
  }
  if (!a.video.empty()) {
    std::filesystem::create_directories(a.video);
    for (std::uint32_t f = 0; f < a.frames; ++f) {
      if (f > 0 || !a.out.empty()) scenario.step();
      advance_to(scenario.frame());
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05u.png", f);
      render_one(a, scenario, h, geometry, (std::filesystem::path(a.video) / name).string());
    }
  }
}

const RegisterCommand reg([](CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Ray-trace a scene through the shared two-level hierarchy (PNG)");
  cmd->add_option("--scene", args->scene, "Scenario kind: paper, clustered, flat, huge, degenerate")
      ->capture_default_str();
  cmd->add_option("--n", args->n, "Objects")->capture_default_str();
  cmd->add_option("--seed", args->seed, "Scenario seed (variant)")->capture_default_str();
  cmd->add_option("--frame", args->frame, "Frame to render (simulated from frame 0)")->capture_default_str();
  // Image sizes are bounded so the frame buffer (4 bytes per pixel) stays
  // within 1 GiB: a larger request is a typo, refused before any work.
  cmd->add_option("--width", args->width, "Image width (pixels)")->check(CLI::Range(1u, 16384u))->capture_default_str();
  cmd->add_option("--height", args->height, "Image height (pixels)")
      ->check(CLI::Range(1u, 16384u))
      ->capture_default_str();
  cmd->add_option("--samples", args->samples, "n x n primary rays per pixel")
      ->check(CLI::Range(1u, 16u))
      ->capture_default_str();
  cmd->add_option("--out", args->out, "PNG file to write");
  cmd->add_option("--video", args->video, "Directory for a numbered PNG sequence (frame_00000.png, ...)");
  cmd->add_option("--frames", args->frames, "Frames of the sequence (with --video)")
      ->check(at_least_one())
      ->capture_default_str();
  cmd->add_flag("--highlight-collisions", args->highlight, "Colour objects the narrow phase finds colliding");
  cmd->add_flag("--no-shadows", args->no_shadows, "Primary rays only");
  cmd->add_option("--cell-limit", args->cell_limit, "Objects per k-d cell")->capture_default_str();
  cmd->add_option("--threads", args->threads, "Threads (0: all cores)")->check(threads_range())->capture_default_str();
  cmd->callback([args] { run(*args); });
});

}  // namespace
}  // namespace hbp::cli
