#include "ptz_driver/emulators/onvif/http_digest.hpp"

#include <openssl/evp.h>

#include <cctype>
#include <cstdio>
#include <map>

namespace ptz::driver {
namespace {

// key=value, key="value" pairs after "Digest "; false when they do not parse.
bool parseParams(std::string_view s, std::map<std::string, std::string>* out) {
  std::size_t i = 0;
  const auto skip = [&] {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == ',')) ++i;
  };
  for (skip(); i < s.size(); skip()) {
    const std::size_t eq = s.find('=', i);
    if (eq == std::string_view::npos) return false;
    std::string key(s.substr(i, eq - i));
    while (!key.empty() && key.back() == ' ') key.pop_back();
    for (char& c : key) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    i = eq + 1;
    std::string value;
    if (i < s.size() && s[i] == '"') {
      const std::size_t end = s.find('"', i + 1);
      if (end == std::string_view::npos) return false;
      value = std::string(s.substr(i + 1, end - i - 1));
      i = end + 1;
    } else {
      const std::size_t end = std::min(s.find(',', i), s.size());
      value = std::string(s.substr(i, end - i));
      while (!value.empty() && value.back() == ' ') value.pop_back();
      i = end;
    }
    if (key.empty() || out->count(key)) return false;  // a repeated key is not guessed at
    (*out)[key] = value;
  }
  return true;
}

}  // namespace

std::string md5Hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_Digest(bytes.data(), bytes.size(), md, &n, EVP_md5(), nullptr);
  std::string hex;
  char two[3];
  for (unsigned int i = 0; i < n; ++i) {
    std::snprintf(two, sizeof two, "%02x", md[i]);
    hex += two;
  }
  return hex;
}

std::string digestChallenge(const DigestCredentials& c) {
  return "Digest realm=\"" + c.realm + "\", qop=\"auth\", nonce=\"" + c.nonce + "\", algorithm=MD5";
}

bool digestValid(std::string_view authorization, std::string_view method, std::string_view uri,
                 const DigestCredentials& c, std::string* why) {
  if (authorization.empty()) return *why = "no Authorization header", false;
  if (authorization.size() > kMaxAuthorizationChars) return *why = "Authorization too long", false;
  if (authorization.substr(0, 7) != "Digest ") return *why = "Authorization is not Digest", false;
  std::map<std::string, std::string> p;
  if (!parseParams(authorization.substr(7), &p)) return *why = "Authorization malformed", false;
  for (const char* key : {"username", "realm", "nonce", "uri", "response"}) {
    if (!p.count(key)) return *why = std::string("Authorization without ") + key, false;
  }
  if (p["username"] != c.user) return *why = "unknown user", false;
  if (p["realm"] != c.realm || p["nonce"] != c.nonce) return *why = "not our challenge", false;
  if (p["uri"] != uri) return *why = "uri is not the request's", false;
  if (p.count("algorithm") && p["algorithm"] != "MD5") return *why = "algorithm not MD5", false;
  const std::string ha1 = md5Hex(c.user + ":" + c.realm + ":" + c.password);
  const std::string ha2 = md5Hex(std::string(method) + ":" + std::string(uri));
  std::string expected;
  if (p.count("qop")) {
    if (p["qop"] != "auth" || !p.count("nc") || !p.count("cnonce")) {
      return *why = "qop other than auth, or without nc and cnonce", false;
    }
    expected = md5Hex(ha1 + ":" + c.nonce + ":" + p["nc"] + ":" + p["cnonce"] + ":auth:" + ha2);
  } else {
    expected = md5Hex(ha1 + ":" + c.nonce + ":" + ha2);
  }
  if (p["response"] != expected) return *why = "wrong response (wrong password?)", false;
  return true;
}

}  // namespace ptz::driver
