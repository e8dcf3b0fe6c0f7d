#include "ptz_driver/heads/onvif/ws_security.hpp"

#include <openssl/evp.h>
#include <openssl/rand.h>
#include <openssl/sha.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include "common/config.hpp"  // ConfigError
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::onvif {

std::string base64Encode(std::string_view bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3), '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::optional<std::string> base64Decode(std::string_view text) {
  if (text.size() % 4 != 0 || text.size() > (1u << 20)) return std::nullopt;
  for (char c : text) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '+' || c == '/' || c == '=';
    if (!ok) return std::nullopt;
  }
  std::string out(3 * text.size() / 4, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0) return std::nullopt;
  // EVP_DecodeBlock counts the padding as zero bytes.
  std::size_t padding = 0;
  if (!text.empty() && text.back() == '=')
    padding = text.size() >= 2 && text[text.size() - 2] == '=' ? 2 : 1;
  out.resize(static_cast<std::size_t>(n) - padding);
  if (base64Encode(out) != text) return std::nullopt;  // '=' inside, or bits left over
  return out;
}

std::string passwordDigest(std::string_view nonce, std::string_view created,
                           std::string_view password) {
  std::string joined;
  joined.reserve(nonce.size() + created.size() + password.size());
  joined.append(nonce).append(created).append(password);
  unsigned char sha[SHA_DIGEST_LENGTH];
  unsigned int length = 0;
  if (EVP_Digest(joined.data(), joined.size(), sha, &length, EVP_sha1(), nullptr) != 1) {
    throw std::runtime_error("OpenSSL could not compute SHA-1");
  }
  return base64Encode(std::string_view(reinterpret_cast<const char*>(sha), length));
}

std::string randomMessageId() {
  std::string b = randomNonce();
  b[6] = static_cast<char>((b[6] & 0x0F) | 0x40);  // version 4
  b[8] = static_cast<char>((b[8] & 0x3F) | 0x80);  // RFC 4122 variant
  std::string id = "urn:uuid:";
  char hex[3];
  for (int i = 0; i < 16; ++i) {
    if (i == 4 || i == 6 || i == 8 || i == 10) id += '-';
    std::snprintf(hex, sizeof hex, "%02x", static_cast<unsigned char>(b[i]));
    id += hex;
  }
  return id;
}

std::string passwordFromFileOrEnv(const std::string& file, const char* env_name) {
  if (!file.empty()) {
    std::ifstream in(file);
    if (!in) throw ConfigError("ONVIF password file '" + file + "': cannot be read");
    std::string line;
    std::getline(in, line);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  }
  const char* env = std::getenv(env_name);
  return env ? env : "";
}

std::string randomNonce() {
  std::string nonce(16, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(nonce.data()), 16) != 1) {
    throw std::runtime_error("OpenSSL's random generator failed");
  }
  return nonce;
}

std::string xsDateTime(double unix_s) {
  double whole = std::floor(unix_s);
  int ms = static_cast<int>(std::lround((unix_s - whole) * 1000.0));
  if (ms == 1000) {
    whole += 1;
    ms = 0;
  }
  const std::time_t t = static_cast<std::time_t>(whole);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[96];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, ms);
  return text;
}

namespace {

bool readInt(std::string_view text, std::size_t at, std::size_t digits, int& value) {
  if (at + digits > text.size()) return false;
  for (std::size_t i = at; i < at + digits; ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
  }
  return std::from_chars(text.data() + at, text.data() + at + digits, value).ec == std::errc();
}

}  // namespace

std::optional<double> parseXsDateTime(std::string_view text) {
  // YYYY-MM-DDThh:mm:ss[.fff][Z|(+|-)hh:mm]
  int year, month, day, hour, minute, second;
  if (text.size() < 19 || text[4] != '-' || text[7] != '-' || text[10] != 'T' || text[13] != ':' ||
      text[16] != ':' || !readInt(text, 0, 4, year) || !readInt(text, 5, 2, month) ||
      !readInt(text, 8, 2, day) || !readInt(text, 11, 2, hour) || !readInt(text, 14, 2, minute) ||
      !readInt(text, 17, 2, second)) {
    return std::nullopt;
  }
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) {
    return std::nullopt;
  }
  std::size_t at = 19;
  double fraction = 0.0, scale = 0.1;
  if (at < text.size() && text[at] == '.') {
    ++at;
    const std::size_t first = at;
    while (at < text.size() && text[at] >= '0' && text[at] <= '9' && at - first < 9) {
      fraction += (text[at] - '0') * scale;
      scale /= 10;
      ++at;
    }
    if (at == first) return std::nullopt;
  }
  int offset_s = 0;
  if (at < text.size()) {
    const char zone = text[at];
    if (zone == 'Z' && at + 1 == text.size()) {
      ++at;
    } else if ((zone == '+' || zone == '-') && at + 6 == text.size() && text[at + 3] == ':') {
      int zh, zm;
      if (!readInt(text, at + 1, 2, zh) || !readInt(text, at + 4, 2, zm) || zh > 14 || zm > 59) {
        return std::nullopt;
      }
      offset_s = (zone == '+' ? 1 : -1) * (zh * 3600 + zm * 60);
      at += 6;
    } else {
      return std::nullopt;
    }
  }
  std::tm utc{};
  utc.tm_year = year - 1900;
  utc.tm_mon = month - 1;
  utc.tm_mday = day;
  utc.tm_hour = hour;
  utc.tm_min = minute;
  utc.tm_sec = second;
  const std::time_t t = timegm(&utc);
  return static_cast<double>(t) - offset_s + fraction;
}

UsernameToken makeUsernameToken(std::string_view user, std::string_view password,
                                double camera_now_s) {
  UsernameToken token;
  token.user = std::string(user);
  token.nonce = randomNonce();
  token.created = xsDateTime(camera_now_s);
  token.digest = passwordDigest(token.nonce, token.created, password);
  return token;
}

std::string securityHeader(const UsernameToken& token) {
  return "<wsse:Security s:mustUnderstand=\"1\" "
         "xmlns:wsse=\"http://docs.oasis-open.org/wss/2004/01/"
         "oasis-200401-wss-wssecurity-secext-1.0.xsd\" "
         "xmlns:wsu=\"http://docs.oasis-open.org/wss/2004/01/"
         "oasis-200401-wss-wssecurity-utility-1.0.xsd\">"
         "<wsse:UsernameToken><wsse:Username>" +
         xmlEscape(token.user) +
         "</wsse:Username><wsse:Password Type=\"http://docs.oasis-open.org/wss/2004/01/"
         "oasis-200401-wss-username-token-profile-1.0#PasswordDigest\">" +
         token.digest +
         "</wsse:Password><wsse:Nonce EncodingType=\"http://docs.oasis-open.org/wss/2004/01/"
         "oasis-200401-wss-soap-message-security-1.0#Base64Binary\">" +
         base64Encode(token.nonce) + "</wsse:Nonce><wsu:Created>" + token.created +
         "</wsu:Created></wsse:UsernameToken></wsse:Security>";
}

}  // namespace ptz::onvif
