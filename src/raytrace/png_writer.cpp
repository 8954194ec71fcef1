// SPDX-License-Identifier: MIT
#include "hbp/raytrace/png_writer.hpp"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "hbp/error.hpp"

namespace hbp {

std::vector<std::uint8_t> encode_png(std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb) {
  if (width == 0 || height == 0 || rgb.size() != 3ull * width * height)
    throw InvalidInput("png: image must be width x height RGB pixels");
  // libpng's simplified API: it keeps its setjmp error handling inside and
  // reports failure through the return value and image.message.
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = width;
  image.height = height;
  image.format = PNG_FORMAT_RGB;
  // The renderer's bytes are written as they are; libpng tags them sRGB
  // (what a viewer assumes for an untagged file anyway).
  // The bound libpng documents for the stream it writes, so one pass
  // suffices; left uninitialised so only the pages written are touched.
  png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(image);
  const auto buffer = std::make_unique_for_overwrite<std::uint8_t[]>(size);
  const int ok = png_image_write_to_memory(&image, buffer.get(), &size, /*convert_to_8_bit=*/0, rgb.data(),
                                           /*row_stride=*/0, /*colormap=*/nullptr);
  if (!ok) {
    const std::string why = image.message;
    png_image_free(&image);
    throw Error("png: libpng could not encode the " + std::to_string(width) + " x " + std::to_string(height) +
                " image: " + why);
  }
  return std::vector<std::uint8_t>(buffer.get(), buffer.get() + size);
}

void write_png(const std::string& path, std::uint32_t width, std::uint32_t height, std::span<const std::uint8_t> rgb) {
  const std::vector<std::uint8_t> png = encode_png(width, height, rgb);
  // Each message says why (the system's reason), not only that it failed.
  const auto cannot = [&path] { return FileError("cannot write '" + path + "': " + std::strerror(errno)); };
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw cannot();
  if (std::fwrite(png.data(), 1, png.size(), f.get()) != png.size()) throw cannot();
  if (std::fflush(f.get()) != 0) throw cannot();
}

}  // namespace hbp
