#pragma once
// The status line and header fields of an answer, written as one string that
// the connection sends with the body's first piece. Written here rather than
// through Beast's serializer, whose field list and buffer views cost more
// than the rest of a cached tile's answer.
#include <cstddef>
#include <string>

#include "server/request_handler.hpp"

namespace terrabake::server {

// "HTTP/1.1", to an HTTP/1.0 client too (RFC 9110 6.2), the status and its
// reason, Date, the reply's fields, then Content-Type and Content-Length
// (`body_length`, what a GET would send, also for HEAD; neither for 1xx, 204
// and 304), and Connection: "close" when the connection ends after this
// answer (`keep` false), "keep-alive" when an HTTP/1.0 client's stays open.
// `version`: the request's, 10 or 11.
std::string responseHead(unsigned version, const HttpReply& reply, std::size_t body_length, bool keep);

// RFC 9110's reason phrase for a status ("Content Too Large" for 413, which
// RFC 7231 named otherwise).
std::string reasonPhrase(int status);

}  // namespace terrabake::server
