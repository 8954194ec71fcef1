// SPDX-License-Identifier: MIT
// libFuzzer target: the `hbp` argument parser. The input is the argument
// list, one argument per line. The app is exactly the one main() parses, with
// the command callbacks removed, so only parsing, validation, conversion and
// the help/error text are exercised. Like main(), a CLI::ParseError is turned
// into an exit code (text captured, not printed) and hbp::Error is a clean
// error; any other exception or a crash is a finding.
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include "app.hpp"
#include "fuzz_support.hpp"
#include "hbp/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kMaxArgs = 48;
  std::vector<std::string> args{"hbp"};
  std::string current;
  for (std::size_t i = 0; i < size && args.size() < kMaxArgs; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\n') {
      args.push_back(current);
      current.clear();
    } else if (c != '\0') {  // argv strings cannot hold NUL
      current += c;
    }
  }
  if (!current.empty() && args.size() < kMaxArgs) args.push_back(current);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  const auto app = hbp::cli::make_app();
  const hbp::cli::RemovedCallbacks kept = hbp::cli::remove_callbacks(*app);  // option storage
  try {
    app->parse(static_cast<int>(args.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    std::ostringstream out, err;
    const int code = app->exit(e, out, err);
    // Help and version requests exit 0 and print; real errors exit non-zero
    // and say something.
    if (code == 0)
      hbp::fuzz::require(!out.str().empty() || !err.str().empty(), "exit 0 from a ParseError without text");
    else
      hbp::fuzz::require(!err.str().empty(), std::string("parse error without a message: ") + e.what());
  } catch (const hbp::Error&) {
  } catch (const std::exception& e) {
    hbp::fuzz::finding(std::string("parse threw a non-CLI exception: ") + e.what());
  }
  return 0;
}
