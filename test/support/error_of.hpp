// What a call throws, as text ("" when it throws nothing): for the tests of error messages.
#pragma once

#include <exception>
#include <functional>
#include <string>

namespace ptz::test {

inline std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace ptz::test
