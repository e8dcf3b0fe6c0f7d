// SOAP 1.2 over HTTP POST with libcurl's easy interface: the action in the Content-Type, connect
// and total timeouts, the reply's size limited while it arrives, no proxy from the environment,
// no redirects, no signals. One HttpClient per thread (it keeps its connection open between
// requests); different clients may run in different threads at once.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "ptz_driver/heads/onvif/soap.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::onvif {

struct HttpOptions {
  long connect_timeout_ms = 2000;
  long total_timeout_ms = 5000;
  std::size_t max_reply_bytes = kMaxXmlBytes;
  // HTTP digest authentication (RFC 7616) for a camera that answers 401 with
  // WWW-Authenticate: Digest; empty password: none. Besides WS-UsernameToken, never instead.
  std::string http_user;
  std::string http_password;
};

// What the server answered: any status (401: the digest refused or not offered; a 400 or 500
// carries a SOAP fault to read) and the body.
struct HttpReply {
  long status = 0;
  std::string body;
};

// "HTTP 500"; a 401 says that authentication was refused.
std::string httpStatusText(long status);

class HttpClient {
 public:
  HttpClient();
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  // POSTs the SOAP message to url (http:// or https://). An Error says what failed: timeout,
  // connection refused, reply too large, connection closed without a reply. A 401 offering
  // Digest is answered with options' credentials (when given), and so is every later request.
  Result<HttpReply> post(std::string_view url, std::string_view action, std::string_view message,
                         const HttpOptions& options = {});

 private:
  Result<HttpReply> perform(std::string_view url, std::string_view action, std::string_view message,
                            const HttpOptions& options, bool digest, bool* digest_asked);

  void* curl_;           // CURL*, kept out of this header
  bool digest_ = false;  // the server asked for HTTP digest once: asked every time since
};

}  // namespace ptz::onvif
