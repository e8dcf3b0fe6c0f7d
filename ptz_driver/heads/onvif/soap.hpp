// SOAP 1.2 for the ONVIF client: the envelope around a request's body (with the WS-Security
// header cameras ask for) and the checked opening of a reply: an Envelope, a Body, a Fault turned
// into an error, the expected response element. Every reader of outside text here returns a
// Result naming the field and the value; nothing throws on hostile bytes.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::onvif {

constexpr std::string_view kSoapNs = "http://www.w3.org/2003/05/soap-envelope";
constexpr std::string_view kDeviceNs = "http://www.onvif.org/ver10/device/wsdl";
constexpr std::string_view kMediaNs = "http://www.onvif.org/ver10/media/wsdl";
constexpr std::string_view kPtzNs = "http://www.onvif.org/ver20/ptz/wsdl";
constexpr std::string_view kSchemaNs = "http://www.onvif.org/ver10/schema";
constexpr std::string_view kAddressingNs = "http://schemas.xmlsoap.org/ws/2004/08/addressing";
constexpr std::string_view kDiscoveryNs = "http://schemas.xmlsoap.org/ws/2005/04/discovery";
constexpr std::string_view kWsseNs =
    "http://docs.oasis-open.org/wss/2004/01/oasis-200401-wss-wssecurity-secext-1.0.xsd";

// A SOAP 1.2 Fault: code "s:Sender", subcode "ter:NotAuthorized", reason in the camera's words.
struct SoapFault {
  std::string code;
  std::string subcode;
  std::string reason;
};

// What went wrong, and the fault when the camera sent one.
struct Error {
  std::string text;
  std::optional<SoapFault> fault;
};

// A value or an Error; no exceptions on the paths that read outside bytes.
template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}      // NOLINT: implicit, as std::optional's
  Result(Error error) : error_(std::move(error)) {}  // NOLINT

  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const T& value() const { return *value_; }
  T& value() { return *value_; }
  const T& operator*() const { return *value_; }
  const T* operator->() const { return &*value_; }
  const std::string& error() const { return error_.text; }
  const std::optional<SoapFault>& fault() const { return error_.fault; }
  const Error& fullError() const { return error_; }

 private:
  std::optional<T> value_;
  Error error_;
};

// The whole message: XML declaration, Envelope with the prefixes s, tds, trt, tptz, tt, wsse,
// the Security header when a token is given, the body.
std::string envelope(std::string_view body_xml, const std::optional<UsernameToken>& token);

// A parsed reply and its response element (the Body's child); nodes point into `doc`.
struct SoapReply {
  XmlDocument doc;
  XmlNode response;
};

// Parses a reply: an s:Envelope (SOAP 1.2 namespace) with an s:Body; a Fault is an error carrying
// the SoapFault; otherwise the Body's first element must be `response_name` in `response_ns`.
Result<SoapReply> openReply(std::string_view bytes, std::string_view response_name,
                            std::string_view response_ns);

// Readers of one element's or attribute's text; `field` names it in the error.
// A finite xs:double within [-max_abs, max_abs] ("1e999", "NaN", "INF", "1x" refused).
Result<double> readDouble(std::string_view text, std::string_view field, double max_abs = 1e9);
// A whole decimal number within [min, max].
Result<long long> readInteger(std::string_view text, std::string_view field, long long min,
                              long long max);
// xs:boolean: true, false, 1, 0.
Result<bool> readBool(std::string_view text, std::string_view field);
// xs:duration as cameras send it (PT1.5S, PT1M, P1DT2H): days, hours, minutes, seconds; years and
// months (of no fixed length) and negative durations are refused; at most ~31 years.
Result<double> readDurationS(std::string_view text, std::string_view field);
// Text of at most max_chars bytes with no control characters (empty allowed when min_chars 0).
Result<std::string> readText(std::string_view text, std::string_view field, std::size_t max_chars,
                             std::size_t min_chars = 1);

// The shortest text that reads back to the same double, in the C locale ("0.25", "-1e-07").
// std::invalid_argument for a non-finite value (the caller's bug, never outside input).
std::string formatNumber(double value);
// xs:duration with milliseconds: PT1.5S.
std::string formatDuration(double seconds);

}  // namespace ptz::onvif
