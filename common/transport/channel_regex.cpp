#include "common/transport/channel_regex.hpp"

namespace ptz {

std::string escapeRegex(const std::string& s) {
  static const std::string kSpecial = "\\^$.|?*+()[]{}";
  std::string out;
  out.reserve(s.size() * 2);
  for (char c : s) {
    if (kSpecial.find(c) != std::string::npos) out += '\\';
    out += c;
  }
  return out;
}

std::string channelsStartingWith(const std::string& prefix) {
  return escapeRegex(prefix) + ".*";
}

}  // namespace ptz
