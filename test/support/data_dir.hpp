// Where the shared test data lives: $PTZ_DATA_DIR, else ../shared/data beside the checkout.
#pragma once

#include <sys/stat.h>
#include <cstdlib>
#include <string>

namespace ptz::test {

inline std::string dataDir() {
  const char* env = std::getenv("PTZ_DATA_DIR");
  return env && *env ? env : PTZ_SOURCE_DIR "/../shared/data";
}

inline bool exists(const std::string& path) {
  struct stat st {};
  return stat(path.c_str(), &st) == 0;
}

// Whether a test without its data may skip: in a user's clone yes, in CI (CI set) no — a green
// CI must have run the tests with known answers (PTZ_ALLOW_SKIP=1 allows it there too).
inline bool skipAllowed() {
  const char* ci = std::getenv("CI");
  const char* allow = std::getenv("PTZ_ALLOW_SKIP");
  return !(ci && *ci) || (allow && std::string(allow) == "1");
}

}  // namespace ptz::test

// At the top of a test that reads shared data: skips with the missing path named, or fails in
// CI.
#define PTZ_REQUIRE_DATA(path)                                                                 \
  do {                                                                                         \
    const std::string ptz_data_path_ = (path);                                                 \
    if (!ptz::test::exists(ptz_data_path_)) {                                                  \
      if (ptz::test::skipAllowed()) {                                                          \
        GTEST_SKIP() << "test data absent: " << ptz_data_path_                                 \
                     << " (set PTZ_DATA_DIR to the shared data folder)";                       \
      }                                                                                        \
      FAIL() << "test data absent in CI: " << ptz_data_path_ << " (PTZ_ALLOW_SKIP=1 to skip)"; \
    }                                                                                          \
  } while (false)
