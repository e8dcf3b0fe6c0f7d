// Runs the independent MCAP checker (test/js/mcap_summary.js: @mcap/core's indexed and stream
// readers, Foxglove's JSON schemas) on a file and returns its JSON, exit code and stderr. Tests
// that use it start with PTZ_REQUIRE_JS(): without test/js/node_modules they skip, or fail when
// PTZ_REQUIRE_JS=1 (scripts/test sets it after `npm ci`).
#pragma once

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "support/data_dir.hpp"
#include "support/run_program.hpp"

namespace ptz::test {

inline std::string jsCheckersDir() {
  return PTZ_SOURCE_DIR "/test/js";
}

// node's absolute path from PATH ("" when absent): posix_spawn does not search PATH.
inline std::string nodePath() {
  const char* env = std::getenv("PATH");
  std::stringstream dirs(env ? env : "/usr/local/bin:/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::string candidate = (dir.empty() ? "." : dir) + "/node";
    if (access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

// What is missing to run the checkers, "" when nothing is.
inline std::string jsCheckersMissing() {
  if (nodePath().empty()) return "node not on PATH (scripts/test installs it)";
  const std::string module = jsCheckersDir() + "/node_modules/@mcap/core/package.json";
  if (!exists(module)) {
    return module + " absent (run: cd test/js && npm ci)";
  }
  return "";
}

inline bool jsRequired() {
  const char* env = std::getenv("PTZ_REQUIRE_JS");
  return env && std::string(env) == "1";
}

struct McapSummary {
  int exit_code = -1;   // 0 good, 1 unreadable or inconsistent, 2 usage, 3 invalid messages
  nlohmann::json json;  // null when the checker printed no JSON
  std::string err;      // the checker's stderr
};

// validate_foxglove: JSON messages checked against Foxglove's schemas (and jsonschema ones against
// the file's own); messages: every message's sequence, times, size and crc32 under
// json["messages"].
inline McapSummary summarizeMcap(const std::string& path, bool validate_foxglove = false,
                                 bool messages = false) {
  std::vector<std::string> argv{nodePath(), jsCheckersDir() + "/mcap_summary.js", path};
  if (validate_foxglove) argv.push_back("--validate-foxglove");
  if (messages) argv.push_back("--messages");
  const ProgramResult r = runProgram(argv);
  McapSummary s;
  s.exit_code = r.exit_code;
  s.err = r.err;
  s.json = nlohmann::json::parse(r.out, nullptr, /*allow_exceptions=*/false);
  if (s.json.is_discarded()) s.json = nullptr;
  return s;
}

}  // namespace ptz::test

// At the top of a test that runs a JS checker: skips naming what is missing, or fails with
// PTZ_REQUIRE_JS=1.
#define PTZ_REQUIRE_JS()                                                                           \
  do {                                                                                             \
    const std::string ptz_js_missing_ = ptz::test::jsCheckersMissing();                            \
    if (!ptz_js_missing_.empty()) {                                                                \
      if (!ptz::test::jsRequired()) GTEST_SKIP() << "JS checker unavailable: " << ptz_js_missing_; \
      FAIL() << "JS checker unavailable with PTZ_REQUIRE_JS=1: " << ptz_js_missing_;               \
    }                                                                                              \
  } while (false)
