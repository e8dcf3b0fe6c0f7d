#include "ptz_driver/heads/onvif/http.hpp"

#include <curl/curl.h>

#include <algorithm>
#include <cctype>
#include <mutex>
#include <stdexcept>

namespace ptz::onvif {
namespace {

struct Sink {
  std::string body;
  std::size_t max_bytes = 0;
  bool too_large = false;
  bool digest_asked = false;  // a WWW-Authenticate: Digest header came
};

// Refusing the bytes (returning less than given) makes libcurl abort the transfer with
// CURLE_WRITE_ERROR: a huge reply costs at most max_bytes.
std::size_t write(char* data, std::size_t size, std::size_t count, void* user) {
  Sink* sink = static_cast<Sink*>(user);
  const std::size_t n = size * count;
  if (sink->body.size() + n > sink->max_bytes) {
    sink->too_large = true;
    return 0;
  }
  sink->body.append(data, n);
  return n;
}

// Each header line of the reply (a 401's too): only whether Digest is offered is kept.
std::size_t header(char* data, std::size_t size, std::size_t count, void* user) {
  Sink* sink = static_cast<Sink*>(user);
  const std::size_t n = size * count;
  std::string line(data, std::min<std::size_t>(n, 256));
  for (char& ch : line) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (line.rfind("www-authenticate:", 0) == 0 && line.find("digest") != std::string::npos) {
    sink->digest_asked = true;
  }
  return n;
}

struct Headers {
  curl_slist* list = nullptr;
  ~Headers() { curl_slist_free_all(list); }
};

}  // namespace

std::string httpStatusText(long status) {
  if (status == 401) {
    return "HTTP 401: authentication refused (HTTP digest: user or password wrong, or none given)";
  }
  return "HTTP " + std::to_string(status);
}

HttpClient::HttpClient() {
  // curl_global_init is not thread-safe: once per process, before any handle.
  static std::once_flag init;
  std::call_once(init, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
  curl_ = curl_easy_init();
  if (!curl_) throw std::runtime_error("libcurl: curl_easy_init failed");
}

HttpClient::~HttpClient() {
  curl_easy_cleanup(curl_);
}

Result<HttpReply> HttpClient::post(std::string_view url, std::string_view action,
                                   std::string_view message, const HttpOptions& options) {
  const bool can_digest = !options.http_password.empty();
  bool digest_asked = false;
  auto reply = perform(url, action, message, options, digest_ && can_digest, &digest_asked);
  // A 401 asking for Digest: the same request again with it, and every later one too (libcurl
  // sends a Digest request's body only after the challenge, so it is not on from the start).
  if (reply && reply->status == 401 && digest_asked && can_digest && !digest_) {
    digest_ = true;
    reply = perform(url, action, message, options, true, &digest_asked);
  }
  return reply;
}

Result<HttpReply> HttpClient::perform(std::string_view url, std::string_view action,
                                      std::string_view message, const HttpOptions& options,
                                      bool digest, bool* digest_asked) {
  if (action.find_first_of("\"\r\n") != std::string_view::npos) {
    return Error{"SOAP action holds a quote or a line break", std::nullopt};
  }
  CURL* c = curl_;
  curl_easy_reset(c);
  Sink sink;
  sink.max_bytes = options.max_reply_bytes;
  Headers headers;
  const std::string content_type =
      "Content-Type: application/soap+xml; charset=utf-8; action=\"" + std::string(action) + "\"";
  headers.list = curl_slist_append(headers.list, content_type.c_str());
  // No "Expect: 100-continue" wait on larger bodies: cameras rarely answer it.
  headers.list = curl_slist_append(headers.list, "Expect:");
  const std::string url_text(url);
  char why[CURL_ERROR_SIZE] = "";
  curl_easy_setopt(c, CURLOPT_URL, url_text.c_str());
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(c, CURLOPT_PROXY, "");  // never a proxy from http_proxy & co.
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 0L);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);  // timeouts without SIGALRM (threads)
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, options.connect_timeout_ms);
  curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, options.total_timeout_ms);
  curl_easy_setopt(c, CURLOPT_POST, 1L);
  curl_easy_setopt(c, CURLOPT_POSTFIELDS, message.data());
  curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(message.size()));
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers.list);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, write);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &sink);
  curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, header);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, &sink);
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, why);
  if (digest) {
    curl_easy_setopt(c, CURLOPT_HTTPAUTH, CURLAUTH_DIGEST);
    curl_easy_setopt(c, CURLOPT_USERNAME, options.http_user.c_str());
    curl_easy_setopt(c, CURLOPT_PASSWORD, options.http_password.c_str());
  }
  const CURLcode code = curl_easy_perform(c);
  // The handle must not keep pointers to this call's locals.
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, nullptr);
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, nullptr);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, nullptr);
  *digest_asked = sink.digest_asked;
  const std::string where = " (" + url_text + ")";
  if (sink.too_large) {
    return Error{"reply larger than " + std::to_string(options.max_reply_bytes) + " bytes" + where,
                 std::nullopt};
  }
  switch (code) {
    case CURLE_OK:
      break;
    case CURLE_OPERATION_TIMEDOUT:
      return Error{"timeout (connect " + std::to_string(options.connect_timeout_ms) +
                       " ms, total " + std::to_string(options.total_timeout_ms) + " ms)" + where,
                   std::nullopt};
    case CURLE_COULDNT_CONNECT:
      return Error{"connection refused or unreachable" + where, std::nullopt};
    case CURLE_GOT_NOTHING:
      return Error{"the server closed the connection without a reply" + where, std::nullopt};
    default:
      return Error{std::string("HTTP: ") + (why[0] ? why : curl_easy_strerror(code)) + where,
                   std::nullopt};
  }
  HttpReply reply;
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &reply.status);
  reply.body = std::move(sink.body);
  return reply;
}

}  // namespace ptz::onvif
