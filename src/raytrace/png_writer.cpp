#include "hbp/raytrace/png_writer.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "hbp/error.hpp"

namespace hbp {

namespace {

// Bits are packed least-significant first (RFC 1951, 3.1.1).
class BitWriter {
 public:
  explicit BitWriter(std::vector<std::uint8_t>& out) : out_(out) {}
  void bits(std::uint32_t value, int count) {
    acc_ |= static_cast<std::uint64_t>(value) << fill_;
    fill_ += count;
    while (fill_ >= 8) {
      out_.push_back(static_cast<std::uint8_t>(acc_));
      acc_ >>= 8;
      fill_ -= 8;
    }
  }
  // Huffman codes are sent most-significant bit first.
  void code(std::uint32_t code, int length) {
    std::uint32_t reversed = 0;
    for (int i = 0; i < length; ++i) reversed |= ((code >> i) & 1u) << (length - 1 - i);
    bits(reversed, length);
  }
  void flush() {
    if (fill_ > 0) bits(0, 8 - fill_);
  }

 private:
  std::vector<std::uint8_t>& out_;
  std::uint64_t acc_ = 0;
  int fill_ = 0;
};

// Fixed Huffman code of a literal/length symbol (RFC 1951, 3.2.6).
void literal_length(BitWriter& w, std::uint32_t symbol) {
  if (symbol < 144) {
    w.code(0x30 + symbol, 8);
  } else if (symbol < 256) {
    w.code(0x190 + symbol - 144, 9);
  } else if (symbol < 280) {
    w.code(symbol - 256, 7);
  } else {
    w.code(0xC0 + symbol - 280, 8);
  }
}

constexpr std::array<std::uint16_t, 29> kLengthBase = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                                       31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<std::uint8_t, 29> kLengthExtra = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                                       2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
constexpr std::array<std::uint16_t, 30> kDistBase = {1,   2,   3,   4,    5,    7,    9,    13,    17,    25,
                                                     33,  49,  65,  97,   129,  193,  257,  385,   513,   769,
                                                     1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
constexpr std::array<std::uint8_t, 30> kDistExtra = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                                     6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

void match(BitWriter& w, std::uint32_t length, std::uint32_t distance) {
  int l = 28;
  while (kLengthBase[l] > length) --l;
  literal_length(w, 257 + l);
  w.bits(length - kLengthBase[l], kLengthExtra[l]);
  int d = 29;
  while (kDistBase[d] > distance) --d;
  w.code(static_cast<std::uint32_t>(d), 5);
  w.bits(distance - kDistBase[d], kDistExtra[d]);
}

constexpr std::uint32_t kWindow = 32768;
constexpr std::uint32_t kMaxMatch = 258;
constexpr int kHashBits = 15;
constexpr int kChain = 24;  // candidates tried per position

std::uint32_t hash3(const std::uint8_t* p) {
  return ((p[0] << 16 | p[1] << 8 | p[2]) * 2654435761u) >> (32 - kHashBits);
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> data, std::uint32_t crc) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::uint8_t b : data) crc = table[(crc ^ b) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

std::uint32_t adler32(std::span<const std::uint8_t> data) {
  std::uint32_t a = 1, b = 0;
  std::size_t i = 0;
  while (i < data.size()) {
    const std::size_t end = std::min(data.size(), i + 5552);  // no overflow before the modulo
    for (; i < end; ++i) {
      a += data[i];
      b += a;
    }
    a %= 65521;
    b %= 65521;
  }
  return b << 16 | a;
}

std::vector<std::uint8_t> zlib_compress(std::span<const std::uint8_t> data) {
  std::vector<std::uint8_t> out = {0x78, 0x01};  // deflate, 32 KiB window, fastest level
  BitWriter w(out);
  w.bits(1, 1);  // BFINAL: one block
  w.bits(1, 2);  // BTYPE 01: fixed Huffman codes
  const auto n = static_cast<std::uint32_t>(data.size());
  std::vector<std::int32_t> head(1u << kHashBits, -1), prev(kWindow, -1);
  auto insert = [&](std::uint32_t pos) {
    if (pos + 3 > n) return;
    const std::uint32_t h = hash3(&data[pos]);
    prev[pos % kWindow] = head[h];
    head[h] = static_cast<std::int32_t>(pos);
  };
  std::uint32_t i = 0;
  while (i < n) {
    std::uint32_t best_len = 0, best_dist = 0;
    if (i + 3 <= n) {
      std::int32_t cand = head[hash3(&data[i])];
      const std::uint32_t limit = std::min(kMaxMatch, n - i);
      for (int chain = 0; chain < kChain && cand >= 0 && i - static_cast<std::uint32_t>(cand) <= kWindow - 1;
           ++chain) {
        const auto c = static_cast<std::uint32_t>(cand);
        std::uint32_t len = 0;
        while (len < limit && data[c + len] == data[i + len]) ++len;
        if (len > best_len) {
          best_len = len;
          best_dist = i - c;
          if (len == limit) break;
        }
        const std::int32_t next = prev[c % kWindow];
        if (next >= cand) break;  // slot reused by a newer position
        cand = next;
      }
    }
    if (best_len >= 3) {
      match(w, best_len, best_dist);
      for (std::uint32_t k = 0; k < best_len; ++k) insert(i + k);
      i += best_len;
    } else {
      literal_length(w, data[i]);
      insert(i);
      ++i;
    }
  }
  literal_length(w, 256);  // end of block
  w.flush();
  const std::uint32_t adler = adler32(data);
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(adler >> s));
  return out;
}

std::vector<std::uint8_t> encode_png(std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb) {
  if (width == 0 || height == 0 || rgb.size() != 3ull * width * height)
    throw InvalidInput("png: image must be width x height RGB pixels");
  // Filtered scanlines: for each row, the filter with the smallest sum of
  // absolute (signed) residuals.
  const std::size_t stride = 3ull * width;
  std::vector<std::uint8_t> raw;
  raw.reserve((stride + 1) * height);
  std::vector<std::uint8_t> trial(stride), best(stride);
  const std::vector<std::uint8_t> zeros(stride, 0);
  for (std::uint32_t y = 0; y < height; ++y) {
    const std::uint8_t* row = &rgb[y * stride];
    const std::uint8_t* up = y > 0 ? &rgb[(y - 1) * stride] : zeros.data();
    std::uint64_t best_score = ~0ull;
    std::uint8_t best_filter = 0;
    for (std::uint8_t f = 0; f < 5; ++f) {
      std::uint64_t score = 0;
      for (std::size_t x = 0; x < stride; ++x) {
        const int a = x >= 3 ? row[x - 3] : 0, b = up[x], c = x >= 3 ? up[x - 3] : 0;
        int pred = 0;
        switch (f) {
          case 1: pred = a; break;
          case 2: pred = b; break;
          case 3: pred = (a + b) / 2; break;
          case 4: {
            const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
            pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
            break;
          }
          default: break;
        }
        trial[x] = static_cast<std::uint8_t>(row[x] - pred);
        score += static_cast<std::uint64_t>(std::abs(static_cast<std::int8_t>(trial[x])));
      }
      if (score < best_score) {
        best_score = score;
        best_filter = f;
        best.swap(trial);
      }
    }
    raw.push_back(best_filter);
    raw.insert(raw.end(), best.begin(), best.end());
  }

  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  auto be32 = [](std::vector<std::uint8_t>& v, std::uint32_t x) {
    for (int s = 24; s >= 0; s -= 8) v.push_back(static_cast<std::uint8_t>(x >> s));
  };
  auto chunk = [&](const char type[4], const std::vector<std::uint8_t>& payload) {
    be32(png, static_cast<std::uint32_t>(payload.size()));
    const std::size_t start = png.size();
    png.insert(png.end(), type, type + 4);
    png.insert(png.end(), payload.begin(), payload.end());
    be32(png, crc32(std::span<const std::uint8_t>(png).subspan(start)));
  };
  std::vector<std::uint8_t> ihdr;
  be32(ihdr, width);
  be32(ihdr, height);
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8-bit, RGB, deflate, adaptive filters, no interlace
  chunk("IHDR", ihdr);
  chunk("IDAT", zlib_compress(raw));
  chunk("IEND", {});
  return png;
}

void write_png(const std::string& path, std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb) {
  const std::vector<std::uint8_t> png = encode_png(width, height, rgb);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw FileError("cannot write '" + path + "'");
  if (std::fwrite(png.data(), 1, png.size(), f.get()) != png.size()) throw FileError("cannot write '" + path + "'");
  if (std::fflush(f.get()) != 0) throw FileError("cannot write '" + path + "'");
}

}  // namespace hbp
