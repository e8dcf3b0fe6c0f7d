// The camera end of WS-Discovery and of HTTP digest, as ptz-sim's ONVIF cameras read outside
// bytes: a datagram as a Probe (readProbe: libxml2's limits) and a header as an Authorization
// (digestValid). Input: one byte choosing which, then the bytes. Properties: nothing throws; a
// Probe read has a printable MessageID of at most kMaxProbeMessageIdChars and its answer relates
// to it; a refusal says why; no Authorization is valid without the password's response.
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/emulators/onvif/http_digest.hpp"
#include "ptz_driver/emulators/onvif/onvif_discovery.hpp"

namespace driver = ptz::driver;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (data[0] & 1) {
    driver::DigestCredentials c{"admin", "pw", "ptz-sim", "0123456789abcdef0123456789abcdef"};
    std::string why;
    if (!driver::digestValid(bytes, "POST", "/onvif/device_service", c, &why)) {
      FUZZ_CHECK(!why.empty(), "a refused Authorization says why");
    } else {
      FUZZ_CHECK(bytes.size() <= driver::kMaxAuthorizationChars, "a long Authorization accepted");
    }
    return 0;
  }
  const driver::ProbeRead r = driver::readProbe(bytes);
  if (!r.ok) {
    FUZZ_CHECK(!r.error.empty() && r.error.size() <= 4096, "a refusal says why, briefly");
    return 0;
  }
  FUZZ_CHECK(!r.message_id.empty() && r.message_id.size() <= driver::kMaxProbeMessageIdChars,
             "MessageID of " + std::to_string(r.message_id.size()));
  for (char ch : r.message_id) {
    FUZZ_CHECK(static_cast<unsigned char>(ch) >= 0x20 && ch != 0x7f, "MessageID printable");
  }
  const driver::DiscoveredCamera cam{"urn:uuid:1", "http://127.0.0.1:1/onvif/device_service", "n",
                                     "h"};
  const std::string answer = driver::probeMatchesMessage(cam, r.message_id, "urn:uuid:2");
  FUZZ_CHECK(answer.find("<a:RelatesTo>") != std::string::npos, "the answer relates");
  return 0;
}
