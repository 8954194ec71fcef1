// SPDX-License-Identifier: MIT
#include "hbp/scene_file.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <exception>
#include <string>

#include "hbp/error.hpp"

// Both formats are defined as little-endian and are read and written with
// plain memory copies; a big-endian port would need byte swaps here.
static_assert(std::endian::native == std::endian::little, "scene files assume a little-endian host");
static_assert(sizeof(float) == 4, "scene files store IEEE-754 binary32");

namespace hbp {

// What a header says about the frames that follow it.
struct SceneHeaderCounts {
  std::uint64_t frames_claimed;  // frames readable with read_frame() once finished
  bool unfinished;               // the writer's "not closed" mark is still set
};

namespace {

// ---- Layout constants (docs/scene-format.md is the specification) --------

constexpr char kNativeMagic[8] = {'H', 'B', 'P', 'S', 'C', 'E', 'N', 'E'};
constexpr std::uint32_t kNativeVersion = 1;
constexpr std::uint32_t kNativeHeaderBytes = 320;
constexpr std::uint32_t kNativeUnfinished = 0xFFFFFFFFu;  // frame count while writing
constexpr std::uint64_t kNativeBoxBytes = 6 * sizeof(float);  // SoA lanes
constexpr std::size_t kNativeFrameCountOffset = 20;

constexpr std::size_t kTextBytes = 128;  // name fields of both formats
constexpr std::uint32_t kBroadmarkHeaderBytes = 304;
constexpr std::uint64_t kBroadmarkBoxBytes = 8 * sizeof(float);  // (x,y,z,0) min, max
constexpr std::size_t kBroadmarkFrameCountOffset = 260;
constexpr std::int32_t kBroadmarkUnfinished = -1;  // numberOfFrames while writing

// Objects transposed per chunk between Broadmark's array of structures and
// our structure of arrays: 256 KiB of records, whatever the scene size.
constexpr std::size_t kChunkObjects = 8192;

const char* const kLaneNames[6] = {"min x", "min y", "min z", "max x", "max y", "max z"};

std::string errno_text() { return std::strerror(errno); }

// ---- Little-endian field access on header bytes ---------------------------

template <typename T>
T load(const unsigned char* bytes, std::size_t offset) {
  T v;
  std::memcpy(&v, bytes + offset, sizeof(T));
  return v;
}

template <typename T>
void store(unsigned char* bytes, std::size_t offset, T v) {
  std::memcpy(bytes + offset, &v, sizeof(T));
}

// Text field: NUL-terminated within its 128 bytes (Broadmark asserts
// strlen <= 127 on read and its writer always ends the field with a NUL).
bool load_text(const unsigned char* bytes, std::size_t offset, std::string& out) {
  const auto* begin = reinterpret_cast<const char*>(bytes + offset);
  const auto* nul = static_cast<const char*>(std::memchr(begin, '\0', kTextBytes));
  if (nul == nullptr) return false;
  out.assign(begin, nul);
  return true;
}

void store_text(unsigned char* bytes, std::size_t offset, const std::string& text) {
  std::memset(bytes + offset, 0, kTextBytes);
  std::memcpy(bytes + offset, text.data(), text.size());
}

// ---- Files ----------------------------------------------------------------

std::uint64_t file_size(std::FILE* f, const std::string& path) {
  if (fseeko(f, 0, SEEK_END) != 0) throw FileError(path + ": cannot seek: " + errno_text());
  const off_t size = ftello(f);
  if (size < 0) throw FileError(path + ": cannot tell the file size: " + errno_text());
  if (fseeko(f, 0, SEEK_SET) != 0) throw FileError(path + ": cannot seek: " + errno_text());
  return static_cast<std::uint64_t>(size);
}

void seek(std::FILE* f, std::uint64_t offset, const std::string& path, const std::string& what) {
  if (fseeko(f, static_cast<off_t>(offset), SEEK_SET) != 0)
    throw FileError(path + ": " + what + ": cannot seek to byte " + std::to_string(offset) + ": " + errno_text());
}

// Reads exactly `bytes`; a short read means the file shrank or is unreadable.
void read_exact(std::FILE* f, void* data, std::size_t bytes, const std::string& path, const std::string& what) {
  if (bytes == 0) return;
  const std::size_t got = std::fread(data, 1, bytes, f);
  if (got != bytes) {
    const std::string why = std::ferror(f) ? errno_text() : "unexpected end of file";
    throw FileError(path + ": " + what + ": short read (" + std::to_string(got) + " of " + std::to_string(bytes) +
                    " bytes): " + why + " (was the file truncated or changed while open?)");
  }
}

std::string world_text(const Aabb& w) {
  auto f = [](float v) { return std::to_string(v); };
  return "(" + f(w.min[0]) + ", " + f(w.min[1]) + ", " + f(w.min[2]) + ") - (" + f(w.max[0]) + ", " + f(w.max[1]) +
         ", " + f(w.max[2]) + ")";
}

// ---- Header classification ------------------------------------------------

// Why the first bytes are not a Broadmark header, or nullptr when they are
// one. Mirrors Broadmark's Scene::ValidateHeader (Core/Scene.h) and adds the
// checks it leaves to assertions-off luck.
const char* broadmark_header_defect(const unsigned char* h, std::uint64_t size) {
  if (size < kBroadmarkHeaderBytes) return "shorter than the 304-byte Broadmark header";
  std::string text;
  if (!load_text(h, 0, text)) return "sceneName is not NUL-terminated within 128 bytes";
  if (!load_text(h, kTextBytes, text)) return "objectsType is not NUL-terminated within 128 bytes";
  const auto objects = load<std::int32_t>(h, 256);
  const auto frames = load<std::int32_t>(h, 260);
  if (objects <= 0) return "numberOfObjects is not positive";
  if (frames < kBroadmarkUnfinished) return "numberOfFrames is negative";
  if (load<std::int32_t>(h, 264) != 0 || load<std::int32_t>(h, 268) != 0) return "padding1/padding2 are not 0";
  if (load<float>(h, 272 + 12) != 0.0f || load<float>(h, 272 + 28) != 0.0f)
    return "worldAabb's 4th components are not 0";
  return nullptr;
}

// Decides the format from the first bytes (up to the Broadmark header size).
SceneFormat classify(const unsigned char* h, std::uint64_t size, const std::string& path) {
  if (size >= sizeof(kNativeMagic) && std::memcmp(h, kNativeMagic, sizeof(kNativeMagic)) == 0)
    return SceneFormat::Native;
  const char* defect = broadmark_header_defect(h, size);
  if (defect == nullptr) return SceneFormat::Broadmark;
  // A damaged native magic still starts with "HBP": say so rather than
  // blaming a Broadmark header the file never claimed to have.
  if (size >= 3 && std::memcmp(h, kNativeMagic, 3) == 0) {
    std::string found;
    for (std::size_t i = 0; i < sizeof(kNativeMagic) && i < size; ++i) {
      const char c = static_cast<char>(h[i]);
      found += (c >= 32 && c < 127) ? c : '?';
    }
    throw FileError(path + ": wrong magic \"" + found + "\" (a native scene starts with \"HBPSCENE\")");
  }
  if (size == 0) throw FileError(path + ": empty file, not a scene");
  throw FileError(path + ": not a scene file: no native magic \"HBPSCENE\", and not a Broadmark .aabbs file (" +
                  defect + ")");
}

// ---- Frame bytes: one frame is one contiguous run after the header -------

// Writes exactly `bytes` (a short write is an error).
void write_exact(std::FILE* f, const void* data, std::size_t bytes, const std::string& path, const char* what) {
  if (bytes != 0 && std::fwrite(data, 1, bytes, f) != bytes)
    throw FileError(path + ": " + what + ": write failed: " + errno_text());
}

// ---- Native codec ---------------------------------------------------------

SceneHeaderCounts read_native_header(const unsigned char* h, std::uint64_t size, const std::string& path,
                               SceneInfo& info) {
  if (size < kNativeHeaderBytes)
    throw FileError(path + ": truncated native header (" + std::to_string(size) + " of " +
                    std::to_string(kNativeHeaderBytes) + " bytes)");
  info.version = load<std::uint32_t>(h, 8);
  if (info.version != kNativeVersion)
    throw FileError(path + ": unsupported native scene version " + std::to_string(info.version) +
                    " (this build reads version " + std::to_string(kNativeVersion) + ")");
  const auto header_bytes = load<std::uint32_t>(h, 12);
  if (header_bytes != kNativeHeaderBytes)
    throw FileError(path + ": corrupt native header: header size " + std::to_string(header_bytes) +
                    ", version 1 has " + std::to_string(kNativeHeaderBytes));
  if (const auto layout = load<std::uint32_t>(h, 48); layout != 0)
    throw FileError(path + ": unsupported native frame layout " + std::to_string(layout) +
                    " (header bytes 48-51; version 1 has only layout 0, structure of arrays)");
  if (load<std::uint32_t>(h, 52) != 0 || load<std::uint64_t>(h, 56) != 0)
    throw FileError(path + ": corrupt native header: reserved bytes 52-63 are not 0");
  info.object_count = load<std::uint32_t>(h, 16);
  const auto frames = load<std::uint32_t>(h, kNativeFrameCountOffset);
  for (int k = 0; k < 3; ++k) {
    info.world.min[k] = load<float>(h, 24 + 4 * k);
    info.world.max[k] = load<float>(h, 36 + 4 * k);
  }
  if (!load_text(h, 64, info.name) || !load_text(h, 64 + kTextBytes, info.objects_type))
    throw FileError(path + ": corrupt native header: name fields are not NUL-terminated");
  return {frames, frames == kNativeUnfinished};
}

void write_native_header(unsigned char* h, std::uint32_t object_count, const Aabb& world, const std::string& name,
                         const std::string& objects_type) {
  std::memcpy(h, kNativeMagic, sizeof kNativeMagic);
  store<std::uint32_t>(h, 8, kNativeVersion);
  store<std::uint32_t>(h, 12, kNativeHeaderBytes);
  store<std::uint32_t>(h, 16, object_count);
  store<std::uint32_t>(h, kNativeFrameCountOffset, kNativeUnfinished);
  for (int k = 0; k < 3; ++k) {
    store<float>(h, 24 + 4 * k, world.min[k]);
    store<float>(h, 36 + 4 * k, world.max[k]);
  }
  store_text(h, 64, name);
  store_text(h, 64 + kTextBytes, objects_type);
}

void check_native_objects(std::uint32_t, const std::string&) {}  // any uint32 count fits

void encode_native_frame_count(unsigned char* field, std::uint32_t frames) {
  store<std::uint32_t>(field, 0, frames);
}

// The frame is stored lane by lane, exactly as BoxArray holds it.
void read_native_frame(std::FILE* f, BoxArray& out, float*, const std::string& path, const std::string& where) {
  const std::size_t n = out.size();
  for (int lane = 0; lane < 6; ++lane) {
    float* dst = lane < 3 ? out.min(lane) : out.max(lane - 3);
    read_exact(f, dst, n * sizeof(float), path, where + " (" + kLaneNames[lane] + ")");
  }
}

void write_native_frame(std::FILE* f, const BoxArray& boxes, float*, const std::string& path,
                        const std::string& where) {
  for (int lane = 0; lane < 6; ++lane) {
    const float* src = lane < 3 ? boxes.min(lane) : boxes.max(lane - 3);
    write_exact(f, src, boxes.size() * sizeof(float), path, where.c_str());
  }
}

// ---- Broadmark codec ------------------------------------------------------

SceneHeaderCounts read_broadmark_header(const unsigned char* h, std::uint64_t, const std::string&, SceneInfo& info) {
  // classify() checked the size, the NUL terminators, the counts' signs,
  // the padding and the w components.
  info.version = 0;
  load_text(h, 0, info.name);
  load_text(h, kTextBytes, info.objects_type);
  info.object_count = static_cast<std::uint32_t>(load<std::int32_t>(h, 256));
  const auto frames = load<std::int32_t>(h, kBroadmarkFrameCountOffset);
  for (int k = 0; k < 3; ++k) {
    info.world.min[k] = load<float>(h, 272 + 4 * k);
    info.world.max[k] = load<float>(h, 288 + 4 * k);
  }
  // + 1: frame 0 is the initial state.
  return {static_cast<std::uint64_t>(frames) + 1, frames == kBroadmarkUnfinished};
}

void write_broadmark_header(unsigned char* h, std::uint32_t object_count, const Aabb& world,
                            const std::string& name, const std::string& objects_type) {
  store_text(h, 0, name);
  store_text(h, kTextBytes, objects_type);
  store<std::int32_t>(h, 256, static_cast<std::int32_t>(object_count));
  store<std::int32_t>(h, kBroadmarkFrameCountOffset, kBroadmarkUnfinished);
  // padding1, padding2 and both w components stay 0.
  for (int k = 0; k < 3; ++k) {
    store<float>(h, 272 + 4 * k, world.min[k]);
    store<float>(h, 288 + 4 * k, world.max[k]);
  }
}

void check_broadmark_objects(std::uint32_t object_count, const std::string& path) {
  if (object_count == 0) throw InvalidInput(path + ": Broadmark scenes need at least one object");
  if (object_count > 0x7FFFFFFFu)
    throw InvalidInput(path + ": " + std::to_string(object_count) +
                       " objects do not fit Broadmark's int32 numberOfObjects");
}

// numberOfFrames does not count the initial state.
void encode_broadmark_frame_count(unsigned char* field, std::uint32_t frames) {
  store<std::int32_t>(field, 0, static_cast<std::int32_t>(frames - 1));
}

// Records are (x, y, z, 0) min, max per object; transposed a chunk at a time.
void read_broadmark_frame(std::FILE* f, BoxArray& out, float* rec, const std::string& path,
                          const std::string& where) {
  const std::size_t n = out.size();
  for (std::size_t first = 0; first < n; first += kChunkObjects) {
    const std::size_t count = std::min(kChunkObjects, n - first);
    read_exact(f, rec, count * kBroadmarkBoxBytes, path, where);
    for (std::size_t i = 0; i < count; ++i) {
      const float* r = rec + 8 * i;
      // Broadmark's Aabb::Validate requires w == 0 in both corners; anything
      // else means the file is not laid out as (x, y, z, 0) records.
      if (r[3] != 0.0f || r[7] != 0.0f)
        throw FileError(path + ": " + where + ": object " + std::to_string(first + i) +
                        ": 4th component of the " + (r[3] != 0.0f ? "min" : "max") + " corner is " +
                        std::to_string(r[3] != 0.0f ? r[3] : r[7]) + ", Broadmark records have 0 there");
      const std::size_t j = first + i;
      for (int a = 0; a < 3; ++a) {
        out.min(a)[j] = r[a];
        out.max(a)[j] = r[4 + a];
      }
    }
  }
}

void write_broadmark_frame(std::FILE* f, const BoxArray& boxes, float* rec, const std::string& path,
                           const std::string& where) {
  const std::size_t n = boxes.size();
  for (std::size_t first = 0; first < n; first += kChunkObjects) {
    const std::size_t count = std::min(kChunkObjects, n - first);
    for (std::size_t i = 0; i < count; ++i) {
      float* r = rec + 8 * i;
      for (int a = 0; a < 3; ++a) {
        r[a] = boxes.min(a)[first + i];
        r[4 + a] = boxes.max(a)[first + i];
      }
      r[3] = 0.0f;
      r[7] = 0.0f;
    }
    write_exact(f, rec, count * kBroadmarkBoxBytes, path, where.c_str());
  }
}

}  // namespace

// ---- The codec table: everything that differs between the formats ----------

struct SceneCodec {
  SceneFormat format;
  const char* kind;                   // the format as error messages name it
  std::uint32_t header_bytes;         // frame 0 starts here
  std::uint64_t box_bytes;            // bytes per object per frame
  std::size_t frame_count_offset;     // the header field close() patches
  std::uint64_t frame_limit;          // frames the count field can hold
  std::uint32_t min_frames;           // a finished scene has at least this many
  std::size_t scratch_floats;         // per-reader/writer transposition buffer
  SceneHeaderCounts (*read_header)(const unsigned char* h, std::uint64_t size, const std::string& path,
                                   SceneInfo& info);
  void (*write_header)(unsigned char* h, std::uint32_t object_count, const Aabb& world, const std::string& name,
                       const std::string& objects_type);
  void (*check_objects)(std::uint32_t object_count, const std::string& path);  // writer's limits
  void (*encode_frame_count)(unsigned char* field, std::uint32_t frames);
  void (*read_frame)(std::FILE* f, BoxArray& out, float* scratch, const std::string& path,
                     const std::string& where);
  void (*write_frame)(std::FILE* f, const BoxArray& boxes, float* scratch, const std::string& path,
                      const std::string& where);
};

namespace {

constexpr SceneCodec kNativeCodec{SceneFormat::Native,
                                  "native",
                                  kNativeHeaderBytes,
                                  kNativeBoxBytes,
                                  kNativeFrameCountOffset,
                                  kNativeUnfinished - 1,
                                  0,
                                  0,
                                  read_native_header,
                                  write_native_header,
                                  check_native_objects,
                                  encode_native_frame_count,
                                  read_native_frame,
                                  write_native_frame};

constexpr SceneCodec kBroadmarkCodec{SceneFormat::Broadmark,
                                     "Broadmark",
                                     kBroadmarkHeaderBytes,
                                     kBroadmarkBoxBytes,
                                     kBroadmarkFrameCountOffset,
                                     0x80000000ull,
                                     1,
                                     kChunkObjects * 8,
                                     read_broadmark_header,
                                     write_broadmark_header,
                                     check_broadmark_objects,
                                     encode_broadmark_frame_count,
                                     read_broadmark_frame,
                                     write_broadmark_frame};

// The reader and writer hold a header in a kNativeHeaderBytes buffer.
static_assert(kNativeCodec.header_bytes <= kNativeHeaderBytes && kBroadmarkCodec.header_bytes <= kNativeHeaderBytes);

const SceneCodec& codec_for(SceneFormat format) {
  return format == SceneFormat::Native ? kNativeCodec : kBroadmarkCodec;
}

}  // namespace

// ---- Format names ------------------------------------------------------------

const char* scene_format_name(SceneFormat f) {
  switch (f) {
    case SceneFormat::Native: return "native";
    case SceneFormat::Broadmark: return "broadmark";
  }
  return "unknown";
}

SceneFormat parse_scene_format(const std::string& name) {
  if (name == "native") return SceneFormat::Native;
  if (name == "broadmark") return SceneFormat::Broadmark;
  throw InvalidInput("unknown scene format '" + name + "' (expected native or broadmark)");
}

std::uint64_t scene_file_bytes(SceneFormat format, std::uint32_t object_count, std::uint32_t frame_count) {
  const SceneCodec& codec = codec_for(format);
  return codec.header_bytes + std::uint64_t{frame_count} * object_count * codec.box_bytes;
}

SceneFormat detect_scene_format(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw FileError(path + ": cannot open: " + errno_text());
  unsigned char h[kNativeHeaderBytes] = {};
  const std::size_t got = std::fread(h, 1, sizeof h, f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw FileError(path + ": cannot read: " + errno_text());
  return classify(h, got, path);
}

// ---- Reader ------------------------------------------------------------------

SceneReader::SceneReader(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) throw FileError(path + ": cannot open: " + errno_text());
  try {
    read_header();
  } catch (...) {
    std::fclose(file_);  // the destructor does not run for a throwing constructor
    file_ = nullptr;
    throw;
  }
}

SceneReader::~SceneReader() {
  if (file_ != nullptr) std::fclose(file_);
}

void SceneReader::read_header() {
  const std::uint64_t size = file_size(file_, path_);
  unsigned char h[kNativeHeaderBytes] = {};
  const std::size_t got = std::fread(h, 1, static_cast<std::size_t>(std::min<std::uint64_t>(size, sizeof h)), file_);
  if (std::ferror(file_)) throw FileError(path_ + ": cannot read: " + errno_text());
  codec_ = &codec_for(classify(h, got, path_));
  info_.format = codec_->format;
  info_.file_bytes = size;

  const SceneHeaderCounts counts = codec_->read_header(h, size, path_, info_);
  data_offset_ = codec_->header_bytes;
  const std::uint64_t frame_bytes = std::uint64_t{info_.object_count} * codec_->box_bytes;
  if (codec_->scratch_floats != 0) scratch_ = std::make_unique<float[]>(codec_->scratch_floats);

  const std::string kind = codec_->kind;
  const std::uint64_t payload = size - data_offset_;
  const std::uint64_t complete = frame_bytes == 0 ? 0 : payload / frame_bytes;
  if (counts.unfinished)
    throw FileError(path_ + ": " + kind + " scene was not finished (its writer stopped before close()); it holds " +
                    std::to_string(complete) + " complete frames of " + std::to_string(info_.object_count) +
                    " objects");
  if (const char* defect = box_defect(info_.world))
    throw FileError(path_ + ": world bounds " + world_text(info_.world) + ": " + defect);

  // 128-bit product: a corrupt header must not wrap around to a matching size.
  const std::uint64_t frames_claimed = counts.frames_claimed;
  const unsigned __int128 expected =
      static_cast<unsigned __int128>(frames_claimed) * frame_bytes + data_offset_;
  if (expected != size) {
    std::string msg = path_ + ": " + kind + " header says " + std::to_string(info_.object_count) + " objects x " +
                      std::to_string(frames_claimed) + " frames";
    if (expected <= ~std::uint64_t{0})
      msg += " = " + std::to_string(static_cast<std::uint64_t>(expected)) + " bytes";
    msg += ", but the file has " + std::to_string(size) + " bytes";
    if (static_cast<unsigned __int128>(size) < expected)
      msg += " (truncated: " + std::to_string(complete) + " complete frames)";
    else
      msg += " (trailing data or wrong counts)";
    throw FileError(msg);
  }
  info_.frame_count = static_cast<std::uint32_t>(frames_claimed);
}

void SceneReader::read_frame(std::uint32_t k, BoxArray& out) {
  if (k >= info_.frame_count)
    throw InvalidInput(path_ + ": frame " + std::to_string(k) + " does not exist (the scene has " +
                       std::to_string(info_.frame_count) + " frames, 0.." +
                       std::to_string(info_.frame_count == 0 ? 0 : info_.frame_count - 1) + ")");
  out.resize(info_.object_count);
  const std::string where = "frame " + std::to_string(k);
  seek(file_, data_offset_ + k * std::uint64_t{info_.object_count} * codec_->box_bytes, path_, where);
  codec_->read_frame(file_, out, scratch_.get(), path_, where);
  out.validate((path_ + ": " + where).c_str());
}

// ---- Writer ------------------------------------------------------------------

SceneWriter::SceneWriter(const std::string& path, SceneFormat format, std::uint32_t object_count, const Aabb& world,
                         const std::string& name, const std::string& objects_type)
    : path_(path),
      codec_(&codec_for(format)),
      object_count_(object_count),
      uncaught_at_construction_(std::uncaught_exceptions()) {
  if (const char* defect = box_defect(world))
    throw InvalidInput(path + ": world bounds " + world_text(world) + ": " + defect);
  for (const std::string* text : {&name, &objects_type}) {
    if (text->size() >= kTextBytes)
      throw InvalidInput(path + ": scene name field '" + *text + "' is longer than 127 bytes");
    if (text->find('\0') != std::string::npos)
      throw InvalidInput(path + ": scene name fields cannot contain NUL bytes");
  }
  codec_->check_objects(object_count, path);
  if (codec_->scratch_floats != 0) scratch_ = std::make_unique<float[]>(codec_->scratch_floats);

  unsigned char h[kNativeHeaderBytes] = {};
  codec_->write_header(h, object_count, world, name, objects_type);

  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw FileError(path + ": cannot create: " + errno_text());
  try {
    write_exact(file_, h, codec_->header_bytes, path_, "header");
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
}

SceneWriter::~SceneWriter() {
  if (file_ == nullptr) return;
  if (std::uncaught_exceptions() > uncaught_at_construction_) {
    std::fclose(file_);  // leave the "unfinished" mark: the scene is partial
    return;
  }
  try {
    close();
  } catch (const std::exception&) {
    // A destructor cannot report; the file stays marked unfinished (close()
    // patches the frame count last), so no reader will take it as complete.
    if (file_ != nullptr) std::fclose(file_);
  }
}

void SceneWriter::write_frame(const BoxArray& boxes) {
  const std::string where = "frame " + std::to_string(frames_);
  if (file_ == nullptr) throw Error(path_ + ": " + where + ": the writer is already closed");
  if (boxes.size() != object_count_)
    throw InvalidInput(path_ + ": " + where + ": " + std::to_string(boxes.size()) +
                       " boxes, but the scene has " + std::to_string(object_count_) + " objects");
  if (frames_ >= codec_->frame_limit) throw InvalidInput(path_ + ": " + where + ": too many frames for the format");
  boxes.validate((path_ + ": " + where).c_str());
  codec_->write_frame(file_, boxes, scratch_.get(), path_, where);
  ++frames_;
}

void SceneWriter::close() {
  if (file_ == nullptr) return;
  std::FILE* f = file_;
  file_ = nullptr;  // whatever happens below, the writer is closed
  auto fail = [&](const std::string& msg) {
    std::fclose(f);
    throw FileError(path_ + ": " + msg);
  };
  if (frames_ < codec_->min_frames) {
    std::fclose(f);
    throw InvalidInput(path_ + ": a " + codec_->kind +
                       " scene needs at least one frame (the initial state); none was written");
  }
  unsigned char field[4];
  codec_->encode_frame_count(field, frames_);
  // Frames reach the disk before the header claims them.
  if (std::fflush(f) != 0) fail("write failed: " + errno_text());
  if (fseeko(f, static_cast<off_t>(codec_->frame_count_offset), SEEK_SET) != 0)
    fail("cannot seek to the header: " + errno_text());
  if (std::fwrite(field, 1, sizeof field, f) != sizeof field) fail("cannot finish the header: " + errno_text());
  if (std::fclose(f) != 0) throw FileError(path_ + ": close failed: " + errno_text());
}

}  // namespace hbp
