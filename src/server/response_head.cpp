#include "server/response_head.hpp"

#include <ctime>

#include <boost/beast/http/status.hpp>

#include "server/http_rules.hpp"

namespace terrabake::server {
namespace {

// Now as an HTTP date, made once a second on each thread.
const std::string& currentHttpDate() {
  thread_local std::time_t made_at = -1;
  thread_local std::string date;
  const std::time_t now = std::time(nullptr);
  if (now != made_at) {
    date = httpDate(now);
    made_at = now;
  }
  return date;
}

}  // namespace

std::string reasonPhrase(int status) {
  if (status == 413) return "Content Too Large";
  namespace http = boost::beast::http;
  const boost::beast::string_view reason = http::obsolete_reason(http::int_to_status(unsigned(status)));
  return std::string(reason.data(), reason.size());
}

std::string responseHead(unsigned version, const HttpReply& reply, std::size_t body_length, bool keep) {
  std::string head;
  head.reserve(384);
  head += "HTTP/1.1 ";
  head += std::to_string(reply.status);
  head += ' ';
  head += reasonPhrase(reply.status);
  head += "\r\nDate: ";
  head += currentHttpDate();
  head += "\r\n";
  for (const auto& [name, value] : reply.headers) {
    head += name;
    head += ": ";
    head += value;
    head += "\r\n";
  }
  const bool bodiless = reply.status == 204 || reply.status == 304 || (reply.status >= 100 && reply.status < 200);
  if (!bodiless) {
    if (!reply.content_type.empty()) {
      head += "Content-Type: ";
      head += reply.content_type;
      head += "\r\n";
    }
    head += "Content-Length: ";
    head += std::to_string(body_length);
    head += "\r\n";
  }
  if (!keep) head += "Connection: close\r\n";
  if (keep && version < 11) head += "Connection: keep-alive\r\n";
  head += "\r\n";
  return head;
}

}  // namespace terrabake::server
