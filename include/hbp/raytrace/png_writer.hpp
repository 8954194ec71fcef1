#pragma once
// PNG output for the ray tracer, with no library: 8-bit RGB, per-row filter
// chosen by the usual minimum-sum heuristic, zlib stream compressed with our
// own LZ77 + fixed-Huffman deflate (rendered images are mostly flat colour,
// which this compresses well).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace hbp {

// The zlib stream (RFC 1950 header, RFC 1951 fixed-Huffman blocks, Adler-32).
std::vector<std::uint8_t> zlib_compress(std::span<const std::uint8_t> data);
std::uint32_t crc32(std::span<const std::uint8_t> data, std::uint32_t crc = 0);
std::uint32_t adler32(std::span<const std::uint8_t> data);

// Encodes width x height RGB pixels (row-major, 3 bytes each) as a PNG file.
std::vector<std::uint8_t> encode_png(std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb);
// Writes it; throws FileError naming the path when it cannot.
void write_png(const std::string& path, std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb);

}  // namespace hbp
