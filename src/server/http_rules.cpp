#include "server/http_rules.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <string_view>

#include "core/fnv1a.hpp"
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

}  // namespace

std::string contentTypeFor(const std::string& file_name) {
  for (const MediaType& media : kMediaTypes) {
    if (endsWith(file_name, media.extension)) return media.type;
  }
  return "application/octet-stream";
}

std::string contentEtag(const std::string& bytes) {
  const std::uint64_t hash = fnv1a(bytes.data(), bytes.size());
  std::string text = "\"";
  appendHex(text, hash, 16);
  text += '-';
  appendHex(text, bytes.size());
  text += '"';
  return text;
}

bool noneMatchHits(const std::string& if_none_match, const std::string& etag) {
  const auto opaque = [](std::string_view tag) { return tag.substr(0, 2) == "W/" ? tag.substr(2) : tag; };
  std::string_view rest(if_none_match);
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    const std::string_view tag = trim(rest.substr(0, comma));
    if (tag == "*" || (!tag.empty() && opaque(tag) == opaque(etag))) return true;
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
  }
  return false;
}

std::string requestPath(const std::string& target) {
  const std::string raw = target.substr(0, target.find_first_of("?#"));
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
bool parseCount(std::string_view text, std::size_t& value) {
  if (text.empty() || text.size() > 18) return false;
  value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
    value = value * 10 + std::size_t(c - '0');
  }
  return true;
}

}  // namespace

ByteRange parseRange(const std::string& range, std::size_t length) {
  ByteRange whole;
  std::string_view text = trim(range);
  constexpr std::string_view kUnit = "bytes=";
  if (text.size() < kUnit.size()) return whole;
  for (std::size_t i = 0; i < kUnit.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(text[i])) != kUnit[i]) return whole;
  }
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

bool isHeaderNameList(const std::string& text) {
  return text.size() <= 1024 && std::all_of(text.begin(), text.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ',' || c == ' ';
         });
}

}  // namespace terrabake::server
