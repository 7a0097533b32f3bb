// libFuzzer target: the server's router. The input is a request target as a
// client sends it ("/layer/3/4/2.png?x=1", "/viewer/%2e%2e/etc"); it goes
// through requestPath() (absolute form, query cut, percent-decoding) and
// parseRoute(), as every request does in RequestHandler::handle. The same
// bytes are also read as a Range header against a body of their own length,
// and as a Host and a Connection field line.
//
// Beyond not crashing, a route must never let through what the router
// promises to refuse: a served file (of the viewer, a vendor package or a
// layer's tileset or archive) with an empty, "." or ".." segment, a
// backslash or a control character; a layer name the layer rule refuses or
// the server reserves; a tile with a negative number or a zoom above kMaxZoom.
// A Host let through holds no space, control character, slash or backslash.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/layer_name.hpp"
#include "core/text.hpp"
#include "core/types.hpp"
#include "fuzz_support.hpp"
#include "server/http_rules.hpp"
#include "server/route.hpp"

namespace {

using namespace terrabake;
using server::Route;

bool safeRelativeFile(const std::string& file) {
  if (file.empty()) return false;
  std::size_t start = 0;
  for (;;) {
    const std::size_t slash = file.find('/', start);
    const std::string segment = file.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    if (segment.empty() || segment == "." || segment == "..") return false;
    for (const char c : segment) {
      const auto u = static_cast<unsigned char>(c);
      if (u < 0x20 || u == 0x7f || c == '\\') return false;
    }
    if (slash == std::string::npos) return true;
    start = slash + 1;
  }
}

void checkLayer(const Route& route) {
  fuzz::require(isLayerName(route.layer), "a routed layer has a layer name");
  fuzz::require(!server::isReservedName(route.layer), "a routed layer is not a reserved name");
}

void checkRoute(const Route& route) {
  switch (route.kind) {
    case Route::Kind::kViewerFile:
    case Route::Kind::kVendorFile:
      fuzz::require(safeRelativeFile(route.file), "a served file stays inside its folder");
      break;
    case Route::Kind::kTileset:
    case Route::Kind::kArchive:
      fuzz::require(safeRelativeFile(route.file), "a layer's file stays inside its folder");
      checkLayer(route);
      break;
    case Route::Kind::kTile:
      fuzz::require(route.tile.z >= 0 && route.tile.z <= kMaxZoom, "a tile's zoom is 0..kMaxZoom");
      fuzz::require(route.tile.x >= 0 && route.tile.y >= 0, "a tile's x and y are not negative");
      checkLayer(route);
      break;
    case Route::Kind::kTileJson:
    case Route::Kind::kElevationTileJson:
      checkLayer(route);
      break;
    case Route::Kind::kBadRequest:
    case Route::Kind::kNotFound:
      fuzz::require(!route.problem.empty(), "a refusal says why");
      break;
    case Route::Kind::kViewerPage:
    case Route::Kind::kLayerList:
    case Route::Kind::kHealth:
      break;
  }
}

void checkRange(const std::string& header, std::size_t length) {
  const server::ByteRange range = server::parseRange(header, length);
  if (range.kind == server::ByteRange::Kind::kPart) {
    fuzz::require(range.first <= range.last && range.last < length, "a range lies within the body");
  }
}

void checkHeadLines(const std::string& text) {
  const std::vector<std::string_view> lines{text};
  if (server::framingProblem(11, lines, false, false).empty()) {
    for (const char c : trim(text)) {
      const auto u = static_cast<unsigned char>(c);
      fuzz::require(u > 0x20 && u != 0x7f && c != '/' && c != '\\', "an accepted Host is host[:port]");
    }
  }
  server::clientKeepsConnection(10, lines);
  server::clientKeepsConnection(11, lines);

  const std::size_t empty = server::emptyLinesAtStart(text);
  fuzz::require(empty <= text.size() && text.find_first_not_of("\r\n") >= std::min(empty, text.size()),
                "only line ends are skipped before a request line");
  if (server::requestLineVersion(text) == server::LineVersion::kLaterMinor) {
    std::string read_as = text;
    read_as.back() = '1';
    fuzz::require(server::requestLineVersion(read_as) == server::LineVersion::kAsItIs,
                  "a later HTTP/1.x read as HTTP/1.1 is spoken");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string target(reinterpret_cast<const char*>(data), size);
  fuzz::onlyProjectErrors([&] {
    const std::string path = server::requestPath(target);
    fuzz::require(path.size() <= target.size(), "decoding never lengthens a path");
    checkRoute(server::parseRoute(path));
    checkRange(target, size);
    checkRange(target, size / 2);
    checkHeadLines(target);
  });
  return 0;
}
