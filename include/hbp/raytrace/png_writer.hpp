// SPDX-License-Identifier: MIT
#pragma once
// PNG output for the ray tracer through libpng's simplified API: 8-bit RGB
// tagged sRGB, libpng's adaptive per-row filters, zlib's default compression.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace hbp {

// Encodes width x height RGB pixels (row-major, 3 bytes each) as a PNG file.
// Throws InvalidInput when the sizes disagree, Error when libpng refuses.
std::vector<std::uint8_t> encode_png(std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb);
// Writes it; throws FileError naming the path when it cannot.
void write_png(const std::string& path, std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb);

}  // namespace hbp
