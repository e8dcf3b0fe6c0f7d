// WS-Security UsernameToken with a password digest, as ONVIF cameras require it (ONVIF Core
// spec 5.12; OASIS UsernameToken Profile 1.0): Digest = Base64(SHA-1(nonce + created + password)).
// The same functions build the client's header and check it in ptz-sim's ONVIF server.
// `created` is the camera's clock, not ours: cameras refuse a token more than a few seconds off.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace ptz::onvif {

std::string base64Encode(std::string_view bytes);
// nullopt for anything that is not canonical Base64.
std::optional<std::string> base64Decode(std::string_view text);

// Base64(SHA-1(nonce + created + password)), nonce as raw bytes.
std::string passwordDigest(std::string_view nonce, std::string_view created,
                           std::string_view password);
// 16 bytes from OpenSSL's random generator.
std::string randomNonce();
// urn:uuid:… with 16 random bytes (a version 4 UUID): a WS-Addressing MessageID or endpoint.
std::string randomMessageId();

// The first line of file (a trailing CR dropped); without a file, the environment variable
// env_name, else "". Throws ConfigError when the file cannot be read. Passwords never in a flag.
std::string passwordFromFileOrEnv(const std::string& file, const char* env_name);

// xs:dateTime in UTC with milliseconds: 2026-12-05T18:33:02.125Z.
std::string xsDateTime(double unix_s);
// Reads an xs:dateTime ("Z" or "+hh:mm" zone; none means UTC, as cameras that omit it mean).
std::optional<double> parseXsDateTime(std::string_view text);

struct UsernameToken {
  std::string user;
  std::string nonce;    // raw bytes
  std::string created;  // xs:dateTime
  std::string digest;   // Base64
};
UsernameToken makeUsernameToken(std::string_view user, std::string_view password,
                                double camera_now_s);
// The <wsse:Security> header element of a SOAP envelope.
std::string securityHeader(const UsernameToken& token);

}  // namespace ptz::onvif
