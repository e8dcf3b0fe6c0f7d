// A camera's side of HTTP digest authentication (RFC 7616 with MD5, as RFC 2617 and most cameras
// have it; qop "auth" or none): the challenge of a 401 and the check of a request's Authorization
// header. The header is outside bytes: bounded, parsed without trust, compared in full.
#pragma once

#include <string>
#include <string_view>

namespace ptz::driver {

constexpr std::size_t kMaxAuthorizationChars = 2048;

struct DigestCredentials {
  std::string user;
  std::string password;
  std::string realm = "ptz-sim";
  std::string nonce;  // the server's, as its challenge gave it
};

// The WWW-Authenticate header's value: Digest realm="…", qop="auth", nonce="…", algorithm=MD5.
std::string digestChallenge(const DigestCredentials& c);

// True when `authorization` (the header's value) answers the challenge for this method and URI
// with the right password; otherwise *why says what is wrong (never the password).
bool digestValid(std::string_view authorization, std::string_view method, std::string_view uri,
                 const DigestCredentials& c, std::string* why);

// Lower-case hex MD5 (OpenSSL), for the response: MD5(HA1:nonce:nc:cnonce:qop:HA2).
std::string md5Hex(std::string_view bytes);

}  // namespace ptz::driver
