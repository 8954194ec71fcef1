// SPDX-License-Identifier: MIT
#pragma once
// Errors the library reports. Every error names the offending item (file,
// frame, object index, option) so a user can find it without a debugger.
#include <stdexcept>
#include <string>

namespace hbp {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Malformed boxes: NaN/Inf coordinates or min > max.
class InvalidInput : public Error {
 public:
  using Error::Error;
};

// Truncated, corrupt or unreadable scene files.
class FileError : public Error {
 public:
  using Error::Error;
};

// An engine or buffer asked to hold more than it was configured for.
class CapacityExceeded : public Error {
 public:
  using Error::Error;
};

}  // namespace hbp
