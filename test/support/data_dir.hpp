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

}  // namespace ptz::test
