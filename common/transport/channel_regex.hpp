// LCM subscribes by regular expression (anchored at both ends): a channel name from a config
// (a prefix such as "SIM.") must be escaped to match only itself.
#pragma once

#include <string>

namespace ptz {

// s with every regex special character backslash-escaped.
std::string escapeRegex(const std::string& s);
// The subscription pattern of every channel whose name starts with prefix.
std::string channelsStartingWith(const std::string& prefix);

}  // namespace ptz
