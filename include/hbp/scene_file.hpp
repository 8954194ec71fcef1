#pragma once
// Recorded scenes: a sequence of frames of n AABBs. Two formats:
//  - native (.hbps): see docs/scene-format.md;
//  - Broadmark (.aabbs): the public broad-phase benchmark's format; frame 0 is
//    the untimed initial state, followed by numberOfFrames timed frames.
// Readers stream one frame at a time (a 10^6-object x 1000-frame scene never
// has to fit in memory) and validate every box they hand out.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"

namespace hbp {

enum class SceneFormat { Native, Broadmark };
const char* scene_format_name(SceneFormat f);
SceneFormat parse_scene_format(const std::string& name);  // throws InvalidInput
// Looks at the first bytes of the file (throws FileError when unreadable).
SceneFormat detect_scene_format(const std::string& path);

struct SceneInfo {
  SceneFormat format = SceneFormat::Native;
  std::uint32_t object_count = 0;
  // Frames readable with read_frame(). For Broadmark this is
  // numberOfFrames + 1 (frame 0 is the initial state).
  std::uint32_t frame_count = 0;
  Aabb world{};
  std::string name;          // Broadmark sceneName (native: empty)
  std::string objects_type;  // Broadmark objectsType (native: empty)
};

class SceneReader {
 public:
  // Opens and validates the header against the file size; throws FileError
  // naming the file and what disagrees.
  explicit SceneReader(const std::string& path);
  ~SceneReader();
  SceneReader(const SceneReader&) = delete;
  SceneReader& operator=(const SceneReader&) = delete;

  const SceneInfo& info() const { return info_; }
  const std::string& path() const { return path_; }
  // Reads frame k (any order; seeks) into out, resized to object_count.
  // Throws FileError on short reads and InvalidInput (naming file, frame and
  // object) on NaN/Inf coordinates or min > max.
  void read_frame(std::uint32_t k, BoxArray& out);

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  SceneInfo info_;
  std::uint64_t data_offset_ = 0;
  std::unique_ptr<float[]> scratch_;
};

class SceneWriter {
 public:
  // Broadmark needs name/objects_type; native ignores them.
  SceneWriter(const std::string& path, SceneFormat format, std::uint32_t object_count,
              const Aabb& world, const std::string& name = "hbp",
              const std::string& objects_type = "paper");
  ~SceneWriter();  // closes (finishing the header) if close() was not called
  SceneWriter(const SceneWriter&) = delete;
  SceneWriter& operator=(const SceneWriter&) = delete;

  // Appends a frame; boxes.size() must equal object_count and boxes must be
  // valid (throws InvalidInput otherwise).
  void write_frame(const BoxArray& boxes);
  // Patches the frame count into the header and closes. For Broadmark,
  // numberOfFrames = frames written - 1 (frame 0 is the initial state), so at
  // least one frame must have been written.
  void close();
  std::uint32_t frames_written() const { return frames_; }

 private:
  std::string path_;
  SceneFormat format_;
  std::FILE* file_ = nullptr;
  std::uint32_t object_count_;
  std::uint32_t frames_ = 0;
  std::unique_ptr<float[]> scratch_;
};

}  // namespace hbp
