// SPDX-License-Identifier: MIT
// `hbp scene gen` writes a scenario's frames to a scene file;
// `hbp scene info` describes (and optionally checks) a scene file.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command_registry.hpp"
#include "option_checks.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"
#include "hbp/scene_file.hpp"
#include "progress.hpp"
#include "support/clock.hpp"

namespace hbp::cli {

namespace {

struct GenOptions {
  ScenarioParams params;
  std::string kind = "paper";
  std::string out;
  std::string format;  // empty: from the extension
  std::string name;    // empty: "<kind> n=<n> seed=<seed>"
};

struct InfoOptions {
  std::string file;
  bool validate = false;
};

std::string human_bytes(std::uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024.0 && u < 4) {
    v /= 1024.0;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", v, units[u]);
  return buf;
}

SceneFormat format_for(const GenOptions& o) {
  if (!o.format.empty()) return parse_scene_format(o.format);
  return std::filesystem::path(o.out).extension() == ".aabbs" ? SceneFormat::Broadmark : SceneFormat::Native;
}

void run_gen(GenOptions& o) {
  ScenarioParams& p = o.params;
  p.kind = parse_scenario_kind(o.kind);
  const SceneFormat format = format_for(o);
  Scenario scenario(p);  // validates the parameters
  // Frame k is the state after k steps in both formats; Broadmark adds the
  // untimed initial state in front of its `frames` timed frames.
  const std::uint32_t count = format == SceneFormat::Broadmark ? p.frames + 1 : p.frames;
  const std::string name =
      o.name.empty() ? std::string(scenario_kind_name(p.kind)) + " n=" + std::to_string(p.n) +
                           " seed=" + std::to_string(p.seed)
                     : o.name;

  const auto start = SteadyClock::now();
  try {
    SceneWriter writer(o.out, format, p.n, scenario.world_bounds(), name, "sphere/cuboid/cylinder/cone");
    ProgressBar bar("writing " + o.out, count, "frames");
    BoxArray boxes;
    for (std::uint32_t k = 0; k < count; ++k) {
      scenario.compute_boxes(boxes);
      writer.write_frame(boxes);
      if (k + 1 < count) scenario.step();
      bar.advance();
    }
    writer.close();
    bar.finish();
  } catch (...) {
    // A partial scene is useless and, being marked unfinished, unreadable:
    // do not leave it behind.
    std::error_code ignored;
    std::filesystem::remove(o.out, ignored);
    throw;
  }
  const double seconds = seconds_since(start);
  const double objects = static_cast<double>(p.n) * count;
  std::printf("wrote %s: %s, %s, %u objects x %u frames, %s in %.2f s (%.3g objects/s)\n", o.out.c_str(),
              scene_format_name(format), name.c_str(), p.n, count,
              human_bytes(scene_file_bytes(format, p.n, count)).c_str(), seconds,
              seconds > 0 ? objects / seconds : 0.0);
}

void run_info(const InfoOptions& o) {
  SceneReader reader(o.file);
  const SceneInfo& info = reader.info();
  const Aabb& w = info.world;
  std::printf("file:         %s\n", o.file.c_str());
  if (info.format == SceneFormat::Native)
    std::printf("format:       native (version %u)\n", info.version);
  else
    std::printf("format:       broadmark (.aabbs)\n");
  std::printf("name:         %s\n", info.name.c_str());
  std::printf("objects type: %s\n", info.objects_type.c_str());
  std::printf("objects:      %u\n", info.object_count);
  if (info.format == SceneFormat::Broadmark)
    std::printf("frames:       %u (initial state + %u timed)\n", info.frame_count,
                info.frame_count == 0 ? 0 : info.frame_count - 1);
  else
    std::printf("frames:       %u\n", info.frame_count);
  std::printf("world:        (%g, %g, %g) - (%g, %g, %g)\n", w.min[0], w.min[1], w.min[2], w.max[0], w.max[1],
              w.max[2]);
  std::printf("size:         %llu bytes (%s)\n", static_cast<unsigned long long>(info.file_bytes),
              human_bytes(info.file_bytes).c_str());
  if (o.validate) {
    // Reading a frame validates every box; the first bad one throws with
    // the file, frame and object in the message.
    ProgressBar bar("checking " + o.file, info.frame_count, "frames");
    BoxArray boxes;
    for (std::uint32_t k = 0; k < info.frame_count; ++k) {
      reader.read_frame(k, boxes);
      bar.advance();
    }
    bar.finish();
    std::printf("valid:        every box of every frame (finite, min <= max)\n");
  }
}

void setup_scene(CLI::App& app) {
  CLI::App* scene = app.add_subcommand("scene", "Generate and inspect scene files (native .hbps, Broadmark .aabbs)");
  scene->require_subcommand(1);

  auto gen_opts = std::make_shared<GenOptions>();
  CLI::App* gen = scene->add_subcommand(
      "gen", "Generate a scenario and write its frames to a scene file (frame k = the state after k steps)");
  ScenarioParams& p = gen_opts->params;
  gen->add_option("--kind", gen_opts->kind, "Scenario kind")
      ->check(CLI::IsMember({"paper", "clustered", "flat", "huge", "degenerate"}))
      ->capture_default_str();
  gen->add_option("-n,--n", p.n, "Number of objects")->check(CLI::Range(1u, kMaxScenarioObjects))->capture_default_str();
  gen->add_option("--frames", p.frames,
                  "Collision-detection cycles: native writes frames 0..F-1, Broadmark the initial state + F")
      ->check(CLI::Range(1u, 0x7FFFFFFEu))
      ->capture_default_str();
  gen->add_option("--seed", p.seed, "Random seed (the paper's variant v is seed v)")->capture_default_str();
  gen->add_option("-o,--out", gen_opts->out, "Output scene file")->required();
  gen->add_option("--format", gen_opts->format, "File format (default: broadmark for *.aabbs, else native)")
      ->check(CLI::IsMember({"native", "broadmark"}));
  gen->add_option("--name", gen_opts->name, "Scene name stored in the file (default: \"<kind> n=<n> seed=<seed>\")");
  gen->add_option("--dt", p.dt, "Time step in seconds (our choice; the paper does not state it)")
      ->capture_default_str();
  gen->add_option("--size-min", p.size_min, "Smallest object size per axis (m)")->capture_default_str();
  gen->add_option("--size-max", p.size_max, "Largest object size per axis (m)")->capture_default_str();
  gen->add_option("--linear-speed", p.linear_speed, "Linear velocity uniform in [-v, v] m/s per axis")
      ->capture_default_str();
  gen->add_option("--angular-speed", p.angular_speed, "Angular velocity uniform in [-w, w] rad/s per axis")
      ->capture_default_str();
  gen->add_option("--volume-per-object", p.volume_per_object, "World volume per object: side = cbrt(this * n) (m^3)")
      ->capture_default_str();
  gen->add_option("--clusters", p.clusters, "clustered: number of Gaussian clusters")->capture_default_str();
  gen->add_option("--cluster-sigma", p.cluster_sigma, "clustered: cluster sigma as a fraction of the world side")
      ->capture_default_str();
  gen->add_option("--huge-objects", p.huge_objects, "huge: objects spanning most of the world")
      ->capture_default_str();
  gen->callback([gen_opts] { run_gen(*gen_opts); });

  auto info_opts = std::make_shared<InfoOptions>();
  CLI::App* info = scene->add_subcommand("info", "Describe a scene file (format, objects, frames, world, size)");
  info->add_option("file", info_opts->file, "Scene file (native or Broadmark, detected from its contents)")
      ->required();
  info->add_flag("--validate", info_opts->validate, "Also read every frame and check every box");
  info->callback([info_opts] { run_info(*info_opts); });
}

const RegisterCommand registered{setup_scene};

}  // namespace

}  // namespace hbp::cli
