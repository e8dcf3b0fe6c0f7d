#include "ptz_driver/heads/onvif/soap.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>
#include <system_error>

namespace ptz::onvif {
namespace {

// At most this much of a bad value is quoted in an error (a hostile value may be huge).
std::string quote(std::string_view value) {
  constexpr std::size_t kMaxQuoted = 64;
  std::string q = "'";
  for (char c : value.substr(0, kMaxQuoted)) {
    q += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  }
  if (value.size() > kMaxQuoted) q += "...";
  return q + "'";
}

Error bad(std::string_view field, std::string_view value, std::string_view why) {
  return {std::string(field) + " " + quote(value) + ": " + std::string(why), std::nullopt};
}

}  // namespace

std::string envelope(std::string_view body_xml, const std::optional<UsernameToken>& token) {
  std::string m =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>"
      "<s:Envelope xmlns:s=\"" +
      std::string(kSoapNs) + "\" xmlns:tds=\"" + std::string(kDeviceNs) + "\" xmlns:trt=\"" +
      std::string(kMediaNs) + "\" xmlns:tptz=\"" + std::string(kPtzNs) + "\" xmlns:tt=\"" +
      std::string(kSchemaNs) + "\" xmlns:wsse=\"" + std::string(kWsseNs) + "\">";
  if (token) m += "<s:Header>" + securityHeader(*token) + "</s:Header>";
  m += "<s:Body>";
  m.append(body_xml);
  m += "</s:Body></s:Envelope>";
  return m;
}

Result<SoapReply> openReply(std::string_view bytes, std::string_view response_name,
                            std::string_view response_ns) {
  SoapReply reply{XmlDocument::parse(bytes), {}};
  if (!reply.doc.ok()) return Error{"reply: " + reply.doc.error(), std::nullopt};
  const XmlNode root = reply.doc.root();
  if (root.localName() != "Envelope" || root.namespaceUri() != kSoapNs) {
    return Error{"reply: the root element is " + quote(root.localName()) + " in namespace " +
                     quote(root.namespaceUri()) + ", not a SOAP 1.2 Envelope",
                 std::nullopt};
  }
  const XmlNode body = root.child("Body");
  if (!body.valid() || body.namespaceUri() != kSoapNs) {
    return Error{"reply: no SOAP 1.2 Body in the Envelope", std::nullopt};
  }
  const std::vector<XmlNode> parts = body.children();
  if (parts.empty()) return Error{"reply: the Body is empty", std::nullopt};
  if (parts[0].localName() == "Fault" && parts[0].namespaceUri() == kSoapNs) {
    const XmlNode f = parts[0];
    SoapFault fault;
    fault.code = f.find({"Code", "Value"}).text();
    fault.subcode = f.find({"Code", "Subcode", "Value"}).text();
    fault.reason = f.find({"Reason", "Text"}).text();
    // Keep the error readable whatever the camera sent.
    auto clip = [](std::string& s) {
      if (s.size() > 256) s = s.substr(0, 256) + "...";
    };
    clip(fault.code);
    clip(fault.subcode);
    clip(fault.reason);
    std::string text = "SOAP fault " + (fault.code.empty() ? "(no code)" : fault.code);
    if (!fault.subcode.empty()) text += " / " + fault.subcode;
    if (!fault.reason.empty()) text += ": " + fault.reason;
    if (fault.subcode.find("NotAuthorized") != std::string::npos) {
      text += " (wrong user or password, or the camera's clock differs from the token's time)";
    }
    return Error{text, fault};
  }
  if (parts[0].localName() != response_name || parts[0].namespaceUri() != response_ns) {
    return Error{"reply: expected " + std::string(response_name) + " in " +
                     std::string(response_ns) + ", got " + quote(parts[0].localName()) + " in " +
                     quote(parts[0].namespaceUri()),
                 std::nullopt};
  }
  reply.response = parts[0];
  return reply;
}

Result<double> readDouble(std::string_view text, std::string_view field, double max_abs) {
  std::string_view digits = text;
  // xs:double allows a leading '+', std::from_chars does not (and one sign only).
  if (!digits.empty() && digits[0] == '+') {
    digits.remove_prefix(1);
    if (digits.empty() || digits[0] == '+' || digits[0] == '-') {
      return bad(field, text, "not a number");
    }
  }
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range) return bad(field, text, "out of range");
  if (ec != std::errc() || end != digits.data() + digits.size()) {
    return bad(field, text, "not a number");
  }
  if (!std::isfinite(value)) return bad(field, text, "not finite");
  if (std::fabs(value) > max_abs) return bad(field, text, "beyond +-" + formatNumber(max_abs));
  return value;
}

Result<long long> readInteger(std::string_view text, std::string_view field, long long min,
                              long long max) {
  long long value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size()) {
    return bad(field, text, "not a whole number");
  }
  if (value < min || value > max) {
    return bad(field, text, "not in " + std::to_string(min) + ".." + std::to_string(max));
  }
  return value;
}

Result<bool> readBool(std::string_view text, std::string_view field) {
  if (text == "true" || text == "1") return true;
  if (text == "false" || text == "0") return false;
  return bad(field, text, "not an xs:boolean");
}

Result<double> readDurationS(std::string_view text, std::string_view field) {
  // P[nD][T[nH][nM][n[.n]S]]
  std::string_view rest = text;
  if (rest.size() < 3 || rest[0] != 'P') return bad(field, text, "not an xs:duration");
  rest.remove_prefix(1);
  double total_s = 0.0;
  bool in_time = false, any = false;
  std::string_view units = "D";  // what may follow next, in order
  while (!rest.empty()) {
    if (rest[0] == 'T') {
      if (in_time) return bad(field, text, "not an xs:duration");
      in_time = true;
      units = "HMS";
      rest.remove_prefix(1);
      continue;
    }
    std::size_t n = 0;
    while (n < rest.size() && ((rest[n] >= '0' && rest[n] <= '9') || rest[n] == '.')) ++n;
    if (n == 0 || n == rest.size()) return bad(field, text, "not an xs:duration");
    const char unit = rest[n];
    const std::size_t at = units.find(unit);
    if (unit == 'Y' || (unit == 'M' && !in_time)) {
      return bad(field, text, "years and months have no fixed length");
    }
    if (at == std::string_view::npos) return bad(field, text, "not an xs:duration");
    if (unit != 'S' && rest.substr(0, n).find('.') != std::string_view::npos) {
      return bad(field, text, "a fraction only in seconds");
    }
    const Result<double> number = readDouble(rest.substr(0, n), field, 1e12);
    if (!number) return number;
    const double scale = unit == 'D' ? 86400 : unit == 'H' ? 3600 : unit == 'M' ? 60 : 1;
    total_s += *number * scale;
    units = units.substr(at + 1);
    rest.remove_prefix(n + 1);
    any = true;
  }
  if (!any || (in_time && text.back() == 'T')) return bad(field, text, "not an xs:duration");
  if (total_s > 1e9) return bad(field, text, "longer than 1e9 s");
  return total_s;
}

Result<std::string> readText(std::string_view text, std::string_view field, std::size_t max_chars,
                             std::size_t min_chars) {
  if (text.size() > max_chars) {
    return bad(field, text,
               "longer than " + std::to_string(max_chars) + " bytes (" +
                   std::to_string(text.size()) + ")");
  }
  if (text.size() < min_chars) return bad(field, text, "missing or empty");
  for (char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return bad(field, text, "holds a control character");
    }
  }
  return std::string(text);
}

std::string formatNumber(double value) {
  if (!std::isfinite(value)) throw std::invalid_argument("ONVIF request with a non-finite number");
  char text[64];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
  if (ec != std::errc()) throw std::invalid_argument("number does not fit");
  return std::string(text, end);
}

std::string formatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) {
    throw std::invalid_argument("ONVIF duration not finite or negative");
  }
  char text[64];
  const auto [end, ec] = std::to_chars(
      text, text + sizeof text, std::round(seconds * 1000.0) / 1000.0, std::chars_format::fixed, 3);
  if (ec != std::errc()) throw std::invalid_argument("duration does not fit");
  std::string s(text, end);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return "PT" + s + "S";
}

}  // namespace ptz::onvif
