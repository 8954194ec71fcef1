// SPDX-License-Identifier: MIT
#pragma once
// CSV fields for `hbp`'s report files (RFC 4180): a text field is always
// enclosed in double quotes, an embedded double quote is doubled; commas,
// CR and LF inside the quotes are then data, not separators.
#include <string>
#include <string_view>

namespace hbp::cli {

inline std::string csv_field(std::string_view text) {
  std::string q;
  q.reserve(text.size() + 2);
  q += '"';
  for (char c : text) {
    if (c == '"') q += '"';
    q += c;
  }
  q += '"';
  return q;
}

}  // namespace hbp::cli
