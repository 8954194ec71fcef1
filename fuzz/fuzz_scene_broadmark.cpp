// SPDX-License-Identifier: MIT
// libFuzzer target: the Broadmark (.aabbs) scene reader on arbitrary bytes; a
// readable scene is rewritten as Broadmark and read back bit for bit.
#include "scene_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hbp::fuzz::check_scene_bytes(data, size, hbp::SceneFormat::Broadmark);
  return 0;
}
