#pragma once
// Small rules of HTTP the request handler applies: media types, ETags and
// their comparison, which header values may be trusted or echoed.
#include <cstddef>
#include <ctime>
#include <string>
#include <string_view>
#include <vector>

namespace terrabake::server {

// The path of a request target ("/a%20b/c.png?x=1" -> "/a b/c.png"): the part
// before '?' or '#', with each %XX decoded (%00 included: the router refuses
// what it must not see); a '%' not followed by two hex digits stays as it is.
// An absolute-form target ("http://host/a.png", as proxies send) gives its
// path ("/a.png"; "/" when it has none).
std::string requestPath(const std::string& target);

// Why a request head must be answered 400 and its connection closed (RFC
// 9112 3.2, 6.3): a Transfer-Encoding whose last coding is not chunked, whose
// body's end cannot be known; no Host in HTTP/1.1, more than one, or one
// that is no host[:port]. "" when none of these.
std::string framingProblem(unsigned version, const std::vector<std::string_view>& host_lines,
                           bool has_transfer_encoding, bool chunked);

// How many bytes at the start of `bytes` are empty lines (CR LF, or a bare
// LF), which a server ignores before a request line (RFC 9112 2.2).
std::size_t emptyLinesAtStart(std::string_view bytes);

// What the version at the end of a request line (without its line end)
// asks of the server, RFC 9112 2.3: a later HTTP/1.x it reads and answers
// as HTTP/1.1, the highest 1.x it knows (RFC 9110 2.5); another major
// version it does not speak (505).
enum class LineVersion {
  kAsItIs,      // HTTP/1.0 or HTTP/1.1, or a line of another shape: the parser's to judge
  kLaterMinor,  // its minor digit, the line's last character, reads as 1
  kOtherMajor,
};
LineVersion requestLineVersion(std::string_view line);

// Whether the client lets the connection stay open after its request: "close"
// in any Connection field line ends it (RFC 9112 9.6); HTTP/1.1 keeps it
// otherwise, HTTP/1.0 only with "keep-alive" (9.3).
bool clientKeepsConnection(unsigned version, const std::vector<std::string_view>& connection_lines);

// `when` as an HTTP date (RFC 9110 5.6.7, IMF-fixdate): "Sun, 06 Nov 1994
// 08:49:37 GMT", in English whatever the locale.
std::string httpDate(std::time_t when);

// What a Range header asks of a body of `length` bytes (RFC 9110 14.2), for a
// single range: "bytes=a-b", "bytes=a-" or "bytes=-n".
struct ByteRange {
  enum class Kind {
    kWhole,          // no Range, one the server may ignore (not bytes, malformed), or several ranges
    kPart,           // bytes first..last, inclusive, both within the body
    kUnsatisfiable,  // starts past the end (or "-0"): 416
  };
  Kind kind = Kind::kWhole;
  std::size_t first = 0;
  std::size_t last = 0;
};
ByteRange parseRange(const std::string& range, std::size_t length);

// An If-Range value that lets a Range apply: the very `etag`, compared
// strongly (a weak tag or a date never matches, so the whole body is sent).
bool ifRangeHolds(const std::string& if_range, const std::string& etag);


// Content-Type for a file by its extension; application/octet-stream when unknown.
std::string contentTypeFor(const std::string& file_name);

// Strong ETag of bytes held in memory (tilejson, layers.json, tiles read from
// an archive): their 64-bit XXH3 hash and length, quoted. Asked for
// every such answer: XXH3 takes 2.5 µs for a 50 KB tile, where FNV-1a took
// 55 µs, half the server's time without its tile cache.
std::string contentEtag(const std::string& bytes);

// True when an If-None-Match value ("*", or a list of tags, weak or strong)
// matches `etag`. RFC 9110 compares weakly here: W/"x" matches "x".
bool noneMatchHits(const std::string& if_none_match, const std::string& etag);

// True when an If-Match value lets a request go on: none given, "*", or a
// list holding `etag` itself (RFC 9110 13.1.1 compares strongly: a weak tag
// never matches).
bool ifMatchHolds(const std::string& if_match, const std::string& etag);

// A method RFC 9110 or RFC 5789 (PATCH) defines, spelled as they do (methods
// are case-sensitive).
bool isStandardMethod(std::string_view method);

// A comma-separated list of header names, safe to echo in
// Access-Control-Allow-Headers.
bool isHeaderNameList(const std::string& text);

}  // namespace terrabake::server
