// Bytes as the transports move them and the protocols build and parse them.
#pragma once

#include <cstdint>
#include <vector>

namespace ptz::driver {

using Bytes = std::vector<uint8_t>;

}  // namespace ptz::driver
