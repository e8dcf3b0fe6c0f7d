// Runs the independent checkers under test/js with node: mcap_summary.js (@mcap/core's indexed
// and stream readers, Foxglove's JSON schemas) on an MCAP file, and the Foxglove WebSocket
// clients (@foxglove/ws-protocol on ws). A test that uses one starts with PTZ_REQUIRE_JS(the
// packages its checker loads): without node or those packages in test/js/node_modules it skips,
// or fails when PTZ_REQUIRE_JS=1 (scripts/test sets it after `npm ci`).
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

// The npm packages (test/js/package.json) each checker loads.
inline const std::vector<std::string> kMcapSummaryPackages = {"@mcap/core", "@foxglove/schemas",
                                                              "ajv", "fzstd"};
inline const std::vector<std::string> kWsCheckPackages = {"@foxglove/ws-protocol", "ws"};

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

// What is missing to run checkers that load `packages`, naming them; "" when nothing is.
inline std::string jsCheckersMissing(
    const std::vector<std::string>& packages = kMcapSummaryPackages) {
  std::string needed, absent;
  for (const std::string& p : packages) {
    needed += (needed.empty() ? "" : ", ") + p;
    if (!exists(jsCheckersDir() + "/node_modules/" + p + "/package.json")) {
      absent += (absent.empty() ? "" : ", ") + p;
    }
  }
  std::string missing;
  if (nodePath().empty()) {
    missing = "node not on PATH (scripts/test installs it)";
  } else if (!absent.empty()) {
    missing = "test/js/node_modules lacks " + absent + " (run: cd test/js && npm ci)";
  } else {
    return "";
  }
  return missing + "; this test needs node and the npm packages " + needed + " under test/js";
}

// PTZ_REQUIRE_JS=1 (scripts/test), or CI: the skip rule of every test (data_dir.hpp), so a green CI
// has run the checkers.
inline bool jsRequired() {
  const char* env = std::getenv("PTZ_REQUIRE_JS");
  return (env && std::string(env) == "1") || !skipAllowed();
}

struct JsCheckResult {
  int exit_code = -1;
  nlohmann::json json;  // null when the checker printed no JSON
  std::string err;      // the checker's stderr
};

// node on test/js/<script> with args; its stdout parsed as JSON.
inline JsCheckResult runJsChecker(const std::string& script, const std::vector<std::string>& args) {
  std::vector<std::string> argv{nodePath(), jsCheckersDir() + "/" + script};
  argv.insert(argv.end(), args.begin(), args.end());
  const ProgramResult r = runProgram(argv);
  JsCheckResult c;
  c.exit_code = r.exit_code;
  c.err = r.err;
  c.json = nlohmann::json::parse(r.out, nullptr, /*allow_exceptions=*/false);
  if (c.json.is_discarded()) c.json = nullptr;
  return c;
}

// exit_code: 0 good, 1 unreadable or inconsistent, 2 usage, 3 invalid messages.
using McapSummary = JsCheckResult;

// validate_foxglove: JSON messages checked against Foxglove's schemas (and jsonschema ones against
// the file's own); messages: every message's sequence, times, size and crc32 under
// json["messages"].
inline McapSummary summarizeMcap(const std::string& path, bool validate_foxglove = false,
                                 bool messages = false) {
  std::vector<std::string> args{path};
  if (validate_foxglove) args.push_back("--validate-foxglove");
  if (messages) args.push_back("--messages");
  return runJsChecker("mcap_summary.js", args);
}

}  // namespace ptz::test

// At the top of a test that runs a JS checker, with the packages it loads (default: those of
// mcap_summary.js): skips naming what is missing, or fails with PTZ_REQUIRE_JS=1.
#define PTZ_REQUIRE_JS(...)                                                                        \
  do {                                                                                             \
    const std::string ptz_js_missing_ = ptz::test::jsCheckersMissing(__VA_ARGS__);                 \
    if (!ptz_js_missing_.empty()) {                                                                \
      if (!ptz::test::jsRequired()) GTEST_SKIP() << "JS checker unavailable: " << ptz_js_missing_; \
      FAIL() << "JS checker unavailable with PTZ_REQUIRE_JS=1: " << ptz_js_missing_;               \
    }                                                                                              \
  } while (false)
