#include "server/http_rules.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <string_view>

#include <xxhash.h>

#include "core/text.hpp"

namespace terrabake::server {
namespace {

struct MediaType {
  const char* extension;
  const char* type;
};

// What a tile viewer loads: tiles, JSON, the page and its scripts and styles.
constexpr MediaType kMediaTypes[] = {
    {".png", "image/png"},
    {".glb", "model/gltf-binary"},
    {".json", "application/json"},
    {".html", "text/html; charset=utf-8"},
    {".js", "text/javascript; charset=utf-8"},
    {".mjs", "text/javascript; charset=utf-8"},
    {".css", "text/css; charset=utf-8"},
    {".map", "application/json"},
    {".svg", "image/svg+xml"},
    {".jpg", "image/jpeg"},
    {".ktx2", "image/ktx2"},
    {".wasm", "application/wasm"},
    {".txt", "text/plain; charset=utf-8"},
    {".pmtiles", "application/vnd.pmtiles"},
};

// The comma-separated items of a field line, without the spaces around them.
std::vector<std::string_view> listItems(std::string_view line) {
  std::vector<std::string_view> items;
  while (true) {
    const std::size_t comma = line.find(',');
    const std::string_view item = trim(line.substr(0, comma));
    if (!item.empty()) items.push_back(item);
    if (comma == std::string_view::npos) return items;
    line.remove_prefix(comma + 1);
  }
}

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

std::string contentTypeFor(const std::string& file_name) {
  for (const MediaType& media : kMediaTypes) {
    if (endsWith(file_name, media.extension)) return media.type;
  }
  return "application/octet-stream";
}

std::string contentEtag(const std::string& bytes) {
  const std::uint64_t hash = XXH3_64bits(bytes.data(), bytes.size());
  std::string text = "\"";
  appendHex(text, hash, 16);
  text += '-';
  appendHex(text, bytes.size());
  text += '"';
  return text;
}

bool noneMatchHits(const std::string& if_none_match, const std::string& etag) {
  const auto opaque = [](std::string_view tag) { return tag.substr(0, 2) == "W/" ? tag.substr(2) : tag; };
  for (const std::string_view tag : listItems(if_none_match)) {
    if (tag == "*" || opaque(tag) == opaque(etag)) return true;
  }
  return false;
}

bool ifMatchHolds(const std::string& if_match, const std::string& etag) {
  if (trim(if_match).empty()) return true;
  for (const std::string_view tag : listItems(if_match)) {
    if (tag == "*" || tag == etag) return true;
  }
  return false;
}

namespace {

// The path part of an absolute-form target (RFC 9112 3.2.2), or the target itself.
std::string_view originForm(std::string_view target) {
  const std::size_t scheme_end = target.find("://");
  if (scheme_end == std::string_view::npos || scheme_end == 0 ||
      !std::all_of(target.begin(), target.begin() + std::ptrdiff_t(scheme_end), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.';
      })) {
    return target;
  }
  const std::size_t path = target.find_first_of("/?#", scheme_end + 3);
  if (path == std::string_view::npos) return "/";
  return target[path] == '/' ? target.substr(path) : "/";
}

}  // namespace

std::string requestPath(const std::string& target) {
  const std::string_view origin = originForm(target);
  const std::string raw(origin.substr(0, origin.find_first_of("?#")));
  const auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string path;
  path.reserve(raw.size());
  for (std::size_t i = 0; i < raw.size(); ++i) {
    if (raw[i] == '%' && i + 2 < raw.size() && hex(raw[i + 1]) >= 0 && hex(raw[i + 2]) >= 0) {
      path += static_cast<char>(hex(raw[i + 1]) * 16 + hex(raw[i + 2]));
      i += 2;
    } else {
      path += raw[i];
    }
  }
  return path;
}

namespace {

// Decimal digits as a number; false when empty, not digits, or more than 18
// of them (so the value fits).
// Decimal digits, however many: a count past 10^18, beyond any file's
// length, is taken as 10^18 (RFC 9110 14.1.2: a last position past the
// end means the end).
bool parseCount(std::string_view text, std::size_t& value) {
  constexpr std::size_t kLargest = 1000000000000000000;
  if (text.empty()) return false;
  value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
    value = std::min(kLargest, value * 10 + std::size_t(c - '0'));
  }
  return true;
}

}  // namespace

ByteRange parseRange(const std::string& range, std::size_t length) {
  ByteRange whole;
  std::string_view text = trim(range);
  constexpr std::string_view kUnit = "bytes=";
  if (!equalsIgnoringCase(text.substr(0, kUnit.size()), kUnit)) return whole;
  text = trim(text.substr(kUnit.size()));
  if (text.find(',') != std::string_view::npos) return whole;  // several ranges: answered whole
  const std::size_t dash = text.find('-');
  if (dash == std::string_view::npos) return whole;
  const std::string_view from = trim(text.substr(0, dash));
  const std::string_view to = trim(text.substr(dash + 1));
  ByteRange part;
  part.kind = ByteRange::Kind::kPart;
  std::size_t a = 0, b = 0;
  if (from.empty()) {  // "-n": the last n bytes
    if (!parseCount(to, b)) return whole;
    if (b == 0 || length == 0) return {ByteRange::Kind::kUnsatisfiable, 0, 0};
    part.first = length - std::min(b, length);
    part.last = length - 1;
    return part;
  }
  if (!parseCount(from, a)) return whole;
  if (to.empty()) {
    b = length;  // "a-": to the end
  } else if (!parseCount(to, b) || b < a) {
    return whole;
  }
  if (a >= length) return {ByteRange::Kind::kUnsatisfiable, 0, 0};
  part.first = a;
  part.last = std::min(b, length - 1);
  return part;
}

bool ifRangeHolds(const std::string& if_range, const std::string& etag) {
  const std::string_view tag = trim(if_range);
  return !tag.empty() && tag.substr(0, 2) != "W/" && tag == etag;
}

namespace {

// A Host value: uri-host [":" port], the host a reg-name, IPv4 address or
// bracketed IP literal (RFC 3986 3.2.2); empty for a target without authority.
bool isHostValue(std::string_view text) {
  const auto made_of = [](std::string_view part, std::string_view symbols) {
    return std::all_of(part.begin(), part.end(), [&](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || symbols.find(c) != std::string_view::npos;
    });
  };
  const auto is_port = [](std::string_view part) {
    return std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  // A reg-name's characters: unreserved, sub-delims and percent-encodings.
  constexpr std::string_view kNameSymbols = "-._~%!$&'()*+,;=";
  std::size_t host_end = text.find(':');
  if (!text.empty() && text.front() == '[') {
    host_end = text.find(']');
    if (host_end == std::string_view::npos || !made_of(text.substr(1, host_end - 1), ":-._~!$&'()*+,;=")) return false;
    ++host_end;
  } else if (!made_of(text.substr(0, host_end), kNameSymbols)) {
    return false;
  }
  if (host_end >= text.size()) return true;
  return text[host_end] == ':' && is_port(text.substr(host_end + 1));
}

}  // namespace

std::string framingProblem(unsigned version, const std::vector<std::string_view>& host_lines,
                           bool has_transfer_encoding, bool chunked) {
  if (has_transfer_encoding && !chunked) return "a Transfer-Encoding whose last coding is not chunked";
  if (host_lines.size() > 1) return "more than one Host";
  if (host_lines.empty() && version >= 11) return "no Host";
  if (!host_lines.empty() && !isHostValue(trim(host_lines.front()))) return "a Host that is no host[:port]";
  return "";
}

std::size_t emptyLinesAtStart(std::string_view bytes) {
  std::size_t at = 0;
  while (true) {
    if (bytes.substr(at, 2) == "\r\n") {
      at += 2;
    } else if (bytes.substr(at, 1) == "\n") {
      at += 1;
    } else {
      return at;
    }
  }
}

LineVersion requestLineVersion(std::string_view line) {
  constexpr std::string_view kName = " HTTP/";
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  // " HTTP/" DIGIT "." DIGIT at the end.
  if (line.size() < kName.size() + 3) return LineVersion::kAsItIs;
  const std::string_view version = line.substr(line.size() - kName.size() - 3);
  if (version.substr(0, kName.size()) != kName || !digit(version[kName.size()]) || version[kName.size() + 1] != '.' ||
      !digit(version[kName.size() + 2])) {
    return LineVersion::kAsItIs;
  }
  if (version[kName.size()] != '1') return LineVersion::kOtherMajor;
  return version[kName.size() + 2] > '1' ? LineVersion::kLaterMinor : LineVersion::kAsItIs;
}

bool clientKeepsConnection(unsigned version, const std::vector<std::string_view>& connection_lines) {
  bool keep_alive = false;
  for (const std::string_view line : connection_lines) {
    for (const std::string_view option : listItems(line)) {
      if (equalsIgnoringCase(option, "close")) return false;
      keep_alive |= equalsIgnoringCase(option, "keep-alive");
    }
  }
  return version >= 11 || keep_alive;
}

std::string httpDate(std::time_t when) {
  static constexpr const char* kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static constexpr const char* kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                            "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  std::tm utc{};
  gmtime_r(&when, &utc);
  char text[32];
  std::snprintf(text, sizeof text, "%s, %02d %s %04d %02d:%02d:%02d GMT", kDays[utc.tm_wday], utc.tm_mday,
                kMonths[utc.tm_mon], utc.tm_year + 1900, utc.tm_hour, utc.tm_min, utc.tm_sec);
  return text;
}

bool isStandardMethod(std::string_view method) {
  static constexpr std::string_view kMethods[] = {"GET",     "HEAD",    "POST",  "PUT",  "DELETE",
                                                  "CONNECT", "OPTIONS", "TRACE", "PATCH"};
  return std::find(std::begin(kMethods), std::end(kMethods), method) != std::end(kMethods);
}

bool isHeaderNameList(const std::string& text) {
  return text.size() <= 1024 && std::all_of(text.begin(), text.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ',' || c == ' ';
         });
}

}  // namespace terrabake::server
