// SPDX-License-Identifier: MIT
#pragma once
// The property both scene-reader fuzz targets check: any byte string either
// opens as a scene whose header agrees with the file size, or is refused with
// hbp::FileError. Frames either read as valid boxes or are refused with
// InvalidInput (bad box, naming the object) or FileError (Broadmark record
// defect). Nothing else may escape, nothing may crash. A fully readable scene
// is then rewritten (in `rewrite_as`) and read back bit for bit.
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "hbp/box_array.hpp"
#include "hbp/error.hpp"
#include "hbp/scene_file.hpp"

namespace hbp::fuzz {

inline bool same_bits(const BoxArray& a, const BoxArray& b) {
  if (a.size() != b.size()) return false;
  for (int k = 0; k < 3; ++k) {
    if (a.size() != 0 && (std::memcmp(a.min(k), b.min(k), a.size() * sizeof(float)) != 0 ||
                          std::memcmp(a.max(k), b.max(k), a.size() * sizeof(float)) != 0))
      return false;
  }
  return true;
}

inline void check_scene_bytes(const std::uint8_t* data, std::size_t size, SceneFormat rewrite_as) {
  static MemFile in("hbp-fuzz-scene-in");
  static MemFile out("hbp-fuzz-scene-out");
  in.assign(data, size);

  std::unique_ptr<SceneReader> reader;
  try {
    reader = std::make_unique<SceneReader>(in.path());
  } catch (const FileError& e) {
    require(std::string(e.what()).find(in.path()) == 0, std::string("FileError does not name the file: ") + e.what());
    return;
  }
  const SceneInfo info = reader->info();
  require(info.file_bytes == size, "file_bytes != file size");
  require(scene_file_bytes(info.format, info.object_count, info.frame_count) == size,
          "header counts disagree with the file size but the reader accepted them");
  require(detect_scene_format(in.path()) == info.format, "detect_scene_format disagrees with the reader");
  require(box_defect(info.world) == nullptr, "reader accepted invalid world bounds");
  require(info.name.size() < 128 && info.objects_type.size() < 128, "name fields longer than 127 bytes");
  if (info.format == SceneFormat::Broadmark)
    require(info.object_count >= 1 && info.frame_count >= 1, "Broadmark scene without objects or initial frame");

  // Frames: all of a short scene; the first four and the last of a long one.
  std::vector<std::uint32_t> frames;
  const bool whole = info.frame_count <= 8;
  for (std::uint32_t k = 0; k < info.frame_count && k < (whole ? 8u : 4u); ++k) frames.push_back(k);
  if (!whole) frames.push_back(info.frame_count - 1);
  std::vector<BoxArray> read(frames.size());
  bool all_valid = true;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    try {
      reader->read_frame(frames[i], read[i]);
      require(read[i].size() == info.object_count, "frame size != object count");
      try {
        read[i].validate("fuzz");
      } catch (const InvalidInput& e) {
        finding(std::string("reader handed out an invalid box: ") + e.what());
      }
    } catch (const InvalidInput& e) {
      require(std::string(e.what()).find("object ") != std::string::npos,
              std::string("InvalidInput does not name the object: ") + e.what());
      all_valid = false;
    } catch (const FileError& e) {
      require(info.format == SceneFormat::Broadmark, std::string("FileError on a native frame: ") + e.what());
      all_valid = false;
    }
  }
  try {
    BoxArray none;
    reader->read_frame(info.frame_count, none);
    finding("read_frame past the last frame did not throw");
  } catch (const InvalidInput&) {
  }
  reader.reset();

  if (!whole || !all_valid) return;
  if (rewrite_as == SceneFormat::Broadmark && (info.frame_count == 0 || info.object_count == 0)) return;
  {
    SceneWriter writer(out.path(), rewrite_as, info.object_count, info.world, info.name, info.objects_type);
    for (const BoxArray& f : read) writer.write_frame(f);
    writer.close();
  }
  SceneReader back(out.path());
  const SceneInfo& b = back.info();
  require(b.format == rewrite_as && b.object_count == info.object_count && b.frame_count == info.frame_count &&
              b.name == info.name && b.objects_type == info.objects_type,
          "rewritten scene's header differs");
  require(std::memcmp(&b.world, &info.world, sizeof(Aabb)) == 0, "rewritten world bounds differ");
  BoxArray again;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    back.read_frame(frames[i], again);
    require(same_bits(read[i], again), "frame " + std::to_string(frames[i]) + " changed in the round trip");
  }
}

}  // namespace hbp::fuzz
