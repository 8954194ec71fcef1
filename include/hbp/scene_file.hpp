// SPDX-License-Identifier: MIT
#pragma once
// Recorded scenes: a sequence of frames of n AABBs. Two formats:
//  - native (.hbps): see docs/scene-format.md;
//  - Broadmark (.aabbs): the public broad-phase benchmark's format; frame 0 is
//    the untimed initial state, followed by numberOfFrames timed frames.
// Readers stream one frame at a time (a 10^6-object x 1000-frame scene never
// has to fit in memory) and validate every box they hand out. Both formats are
// little-endian; files are never trusted: every header field is checked
// against the file size before a frame is read.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"

namespace hbp {

enum class SceneFormat { Native, Broadmark };
struct SceneCodec;  // one per format (scene_file.cpp): header and frame layout
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
  std::string name;          // Broadmark sceneName / native name field
  std::string objects_type;  // Broadmark objectsType / native objects-type field
  std::uint32_t version = 0;    // native format version (Broadmark: 0)
  std::uint64_t file_bytes = 0;  // size of the file, as checked against the header
};

// Bytes a complete scene file of this shape occupies (frames as readable by
// read_frame, so for Broadmark the initial state counts as a frame).
std::uint64_t scene_file_bytes(SceneFormat format, std::uint32_t object_count,
                               std::uint32_t frame_count);

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
  const SceneCodec* codec_ = nullptr;  // chosen once, from the header
  std::unique_ptr<float[]> scratch_;  // the codec's transposition buffer (Broadmark records of one chunk)

  void read_header();
};

class SceneWriter {
 public:
  // Both formats store name/objects_type (at most 127 bytes each; longer
  // strings throw InvalidInput rather than being cut). Throws FileError when
  // the file cannot be created.
  SceneWriter(const std::string& path, SceneFormat format, std::uint32_t object_count,
              const Aabb& world, const std::string& name = "hbp",
              const std::string& objects_type = "paper");
  // Closes (finishing the header) if close() was not called, unless the
  // writer is being destroyed by an exception: then the file keeps its
  // "unfinished" mark and readers refuse it instead of accepting a partial
  // scene as complete.
  ~SceneWriter();
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
  const SceneCodec* codec_;  // chosen once, from the format
  std::FILE* file_ = nullptr;
  std::uint32_t object_count_;
  std::uint32_t frames_ = 0;
  std::unique_ptr<float[]> scratch_;  // the codec's transposition buffer (Broadmark records of one chunk)
  int uncaught_at_construction_ = 0;
};

}  // namespace hbp
