// Tests of `terrabake serve` that need no server: the serve config (file,
// defaults, errors), the router (routes, malformed and unknown paths), the
// HTTP rules (If-None-Match, content types, hosts), the tile cache (its
// bound and eviction order) and files read in parts.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "core/error.hpp"
#include "core/open_files.hpp"
#include "core/text.hpp"
#include "core/types.hpp"
#include "io/tile_files.hpp"
#include "server/http_rules.hpp"
#include "server/response_head.hpp"
#include "server/route.hpp"
#include "server/served_folder.hpp"
#include "server/stored_state.hpp"
#include "server/tile_cache.hpp"
#include "server_helpers.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using server::FileContent;
using server::Route;
using server::TileCache;
using io::TileFormat;
using test::AllFilesOpen;
using test::caseDir;
using test::readBytes;
using test::startsWith;
using test::writeText;

const fs::path kSourceDir = fs::path(TERRABAKE_SOURCE_DIR).lexically_normal();

// --- The serve config --------------------------------------------------------

TEST(ServeConfig, LoadsTheSampleServeFile) {
  const std::string path = (kSourceDir / "config" / "serve.yaml").string();
  const config::ServeConfig config = config::loadServeConfig(path);
  EXPECT_EQ(config.tiles_dir, (kSourceDir / "tiles").string());
  EXPECT_EQ(config.layer_jobs, std::vector<std::string>{(kSourceDir / "config" / "sample.yaml").string()});
  EXPECT_EQ(config.bind, "127.0.0.1");
  EXPECT_EQ(config.port, 8080);
  EXPECT_EQ(config.tile_max_age_s, 3600);
  EXPECT_NO_THROW(config::validate(config, path));
}

TEST(ServeConfig, DefaultsBindToThisMachineAndServeTheBuiltInViewer) {
  const config::ServeConfig config;
  EXPECT_EQ(config.bind, "127.0.0.1");
  EXPECT_TRUE(config.layer_jobs.empty());
  EXPECT_EQ(fs::path(config.viewer_dir), kSourceDir / "src" / "server" / "viewer");
  EXPECT_NO_THROW(config::validate(config, "defaults"));
}

TEST(ServeConfig, ReadmeDocumentsEveryKey) {
  const std::string readme = readBytes(kSourceDir / "config" / "README.md");
  ASSERT_FALSE(readme.empty()) << "config/README.md is missing";
  for (const config::KeyInfo& key : config::listServeKeys()) {
    EXPECT_NE(readme.find("`" + key.name + "`"), std::string::npos) << key.name << " is not in config/README.md";
  }
}

TEST(ServeConfig, ErrorsNameFileLineAndKey) {
  const fs::path dir = caseDir();
  const fs::path path = dir / "serve.yaml";
  writeText(path, "tiles: t\nhttp:\n  port: 70000\n");
  try {
    config::loadServeConfig(path.string());
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":3: http.port: must be between 0 and 65535, got 70000");
  }
  writeText(path, "htp:\n  port: 1\n");
  try {
    config::loadServeConfig(path.string());
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":1: htp: unknown key (did you mean 'http'?)");
  }
  config::ServeConfig config;
  try {
    config::applyOverride(config, "http.bind", {"a host"}, "--bind");
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), "--bind: http.bind: must be an IP address or a host name, got 'a host'");
  }
}

TEST(ServeConfig, EmptyFileMeansDefaultsAndLayersMayBeAnEmptyList) {
  const fs::path dir = caseDir();
  writeText(dir / "empty.yaml", "");
  EXPECT_EQ(config::loadServeConfig((dir / "empty.yaml").string()).port, 8080);
  writeText(dir / "none.yaml", "layers: []\n");
  EXPECT_TRUE(config::loadServeConfig((dir / "none.yaml").string()).layer_jobs.empty());
}

// --- Routes and HTTP rules, without a server ----------------------------------

TEST(ServeRoutes, KnownRoutes) {
  EXPECT_EQ(server::parseRoute("/").kind, Route::Kind::kViewerPage);
  EXPECT_EQ(server::parseRoute("/health").kind, Route::Kind::kHealth);
  EXPECT_EQ(server::parseRoute("/layers.json").kind, Route::Kind::kLayerList);
  const Route viewer = server::parseRoute("/viewer/lib/viewer.js");
  EXPECT_EQ(viewer.kind, Route::Kind::kViewerFile);
  EXPECT_EQ(viewer.file, "lib/viewer.js");
  const Route three = server::parseRoute("/vendor/three/examples/jsm/controls/OrbitControls.js");
  EXPECT_EQ(three.kind, Route::Kind::kVendorFile);
  EXPECT_EQ(three.file, "examples/jsm/controls/OrbitControls.js");
  const Route maplibre = server::parseRoute("/vendor/maplibre-gl/maplibre-gl-worker.mjs");
  EXPECT_EQ(maplibre.kind, Route::Kind::kVendorFile);
  EXPECT_EQ(maplibre.package, "maplibre-gl");
  EXPECT_EQ(maplibre.file, "maplibre-gl-worker.mjs");
  const Route tilejson = server::parseRoute("/sample/tilejson.json");
  EXPECT_EQ(tilejson.kind, Route::Kind::kTileJson);
  EXPECT_EQ(tilejson.layer, "sample");
  const Route tile = server::parseRoute("/sample/12/2161/1448.hires.glb");
  ASSERT_EQ(tile.kind, Route::Kind::kTile);
  EXPECT_EQ(tile.layer, "sample");
  EXPECT_EQ(tile.tile, (TileId{12, 2161, 1448}));
  EXPECT_EQ(tile.format, io::TileFormat::kHighResGlb);
  EXPECT_EQ(server::parseRoute("/sample/0/0/0.png").format, io::TileFormat::kPng);
  EXPECT_EQ(server::parseRoute("/sample/0/0/0.glb").format, io::TileFormat::kGlb);
  const Route tileset = server::parseRoute("/sample/tileset.json");
  ASSERT_EQ(tileset.kind, Route::Kind::kTileset);
  EXPECT_EQ(tileset.layer, "sample");
  EXPECT_EQ(tileset.file, "tileset.json");
  const Route external = server::parseRoute("/sample/tilesets/14/8886/4757.json");
  ASSERT_EQ(external.kind, Route::Kind::kTileset);
  EXPECT_EQ(external.file, "tilesets/14/8886/4757.json");
  const Route archive = server::parseRoute("/sample/sample.meshes.pmtiles");
  ASSERT_EQ(archive.kind, Route::Kind::kArchive);
  EXPECT_EQ(archive.layer, "sample");
  EXPECT_EQ(archive.file, "sample.meshes.pmtiles");
  EXPECT_EQ(server::parseRoute("/sample/.pmtiles").kind, Route::Kind::kNotFound);
}

TEST(ServeRoutes, MalformedPathsAreBadRequests) {
  for (const char* path :
       {"/sample/a/b/c.png", "/sample/-1/0/0.png", "/sample/12/-5/3.png", "/sample/12/1/99999999999.png",
        "/sample/25/0/0.png", "/sample/12/1/1.jpg", "/sample/12/1/1", "/sample/12/1/1.", "/sample/012/1/1.png",
        "/sample/+3/1/1.png", "/sample/12/1/2/3.png", "/sample/12/1", "/sample/../etc/passwd", "/viewer/../x",
        "/viewer/./x", "//etc/passwd", "/viewer//etc/passwd", "/vendor/three/../../x", "/viewer/a\\b",
        "/sample/12/1/1.png/", "relative/path", "/a b/tilejson.json", "/sample/tilesets/14/1/2.png",
        "/sample/tilesets/x/1/2.json", "/sample/tilesets/14/1/02.json", "/sample/tilesets/25/1/2.json"}) {
    EXPECT_EQ(server::parseRoute(path).kind, Route::Kind::kBadRequest) << path;
  }
  EXPECT_EQ(server::parseRoute(std::string("/viewer/a\0b", 11)).kind, Route::Kind::kBadRequest);
  EXPECT_EQ(server::parseRoute("/viewer/a\nb").kind, Route::Kind::kBadRequest);
  // A layer name too long for a folder; the answer quotes only its start.
  const Route long_name = server::parseRoute("/" + std::string(10'000, 'a') + "/tilejson.json");
  EXPECT_EQ(long_name.kind, Route::Kind::kBadRequest);
  EXPECT_LT(long_name.problem.size(), 300u) << long_name.problem;
}

TEST(ServeRoutes, UnknownPathsAreNotFound) {
  for (const char* path : {"/favicon.ico", "/sample", "/sample/other.json", "/vendor/other/x.js", "/viewer"}) {
    EXPECT_EQ(server::parseRoute(path).kind, Route::Kind::kNotFound) << path;
  }
}

TEST(ServeHttpRules, IfNoneMatchComparesWeakly) {
  const std::string etag = "\"abc-12\"";
  EXPECT_TRUE(server::noneMatchHits("\"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("W/\"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("\"x\", \"abc-12\"", etag));
  EXPECT_TRUE(server::noneMatchHits("*", etag));
  EXPECT_FALSE(server::noneMatchHits("", etag));
  EXPECT_FALSE(server::noneMatchHits("\"abc-13\"", etag));
  EXPECT_FALSE(server::noneMatchHits("abc-12", etag));
}

TEST(ServeHttpRules, IfMatchComparesStrongly) {
  const std::string etag = "\"abc-12\"";
  EXPECT_TRUE(server::ifMatchHolds("", etag));
  EXPECT_TRUE(server::ifMatchHolds("\"abc-12\"", etag));
  EXPECT_TRUE(server::ifMatchHolds("\"x\", \"abc-12\"", etag));
  EXPECT_TRUE(server::ifMatchHolds("*", etag));
  EXPECT_FALSE(server::ifMatchHolds("W/\"abc-12\"", etag));
  EXPECT_FALSE(server::ifMatchHolds("\"abc-13\"", etag));
}

TEST(ServeHttpRules, ContentTypes) {
  EXPECT_EQ(server::contentTypeFor("a/b.png"), "image/png");
  EXPECT_EQ(server::contentTypeFor("1.hires.glb"), "model/gltf-binary");
  EXPECT_EQ(server::contentTypeFor("tilejson.json"), "application/json");
  EXPECT_TRUE(startsWith(server::contentTypeFor("index.html"), "text/html"));
  EXPECT_TRUE(startsWith(server::contentTypeFor("three.module.js"), "text/javascript"));
  EXPECT_TRUE(startsWith(server::contentTypeFor("x.mjs"), "text/javascript"));
  EXPECT_EQ(server::contentTypeFor("x.bin"), "application/octet-stream");
}

TEST(ServeHttpRules, RequestPathsArePercentDecodedWithoutTheQuery) {
  EXPECT_EQ(server::requestPath("/a%20b/c.png?x=1"), "/a b/c.png");
  EXPECT_EQ(server::requestPath("/viewer/%2e%2E/x#frag"), "/viewer/../x");
  EXPECT_EQ(server::requestPath("/a%2fb"), "/a/b");
  EXPECT_EQ(server::requestPath("/a%00b"), std::string("/a\0b", 4));  // the router refuses it
  EXPECT_EQ(server::requestPath("/100%/x%4"), "/100%/x%4");            // not an escape: left as it is
  EXPECT_EQ(server::requestPath("/x%zz"), "/x%zz");
}

TEST(ServeHttpRules, AbsoluteFormTargetsGiveTheirPath) {
  EXPECT_EQ(server::requestPath("http://example.com/a/b.png?x=1"), "/a/b.png");
  EXPECT_EQ(server::requestPath("HTTPS://example.com:8080/a%20b"), "/a b");
  EXPECT_EQ(server::requestPath("http://example.com"), "/");
  EXPECT_EQ(server::requestPath("http://example.com?x"), "/");
  EXPECT_EQ(server::requestPath("/a/http://b"), "/a/http://b");  // an origin-form path stays whole
}

TEST(ServeHttpRules, HeadsThatMustBeRefused) {
  using Lines = std::vector<std::string_view>;
  EXPECT_EQ(server::framingProblem(11, Lines{"x"}, false, false), "");
  EXPECT_EQ(server::framingProblem(11, Lines{"x"}, true, true), "");
  EXPECT_NE(server::framingProblem(11, Lines{"x"}, true, false), "");  // Transfer-Encoding: gzip
  EXPECT_NE(server::framingProblem(11, Lines{}, false, false), "");
  EXPECT_EQ(server::framingProblem(10, Lines{}, false, false), "");  // HTTP/1.0 need not send Host
  EXPECT_NE(server::framingProblem(10, Lines{"a", "b"}, false, false), "");
  EXPECT_NE(server::framingProblem(11, Lines{"a b"}, false, false), "");
  EXPECT_NE(server::framingProblem(11, Lines{"a/b"}, false, false), "");
  EXPECT_EQ(server::framingProblem(11, Lines{"tiles.example.com:8080"}, false, false), "");
  EXPECT_EQ(server::framingProblem(11, Lines{"[::1]:80"}, false, false), "");
  EXPECT_EQ(server::framingProblem(11, Lines{""}, false, false), "");           // a target without authority
  EXPECT_EQ(server::framingProblem(11, Lines{"x,y"}, false, false), "");        // a reg-name may hold sub-delims
  EXPECT_EQ(server::framingProblem(11, Lines{"10.0.0.1:"}, false, false), "");  // port = *DIGIT
  EXPECT_EQ(server::framingProblem(11, Lines{"[v1.x]"}, false, false), "");     // IPvFuture
  for (const std::string_view host : {"x:abc", "1.2.3.4:80:90", "[::1", "[::1]x", "::1", "a@b", "[::1]:8a"}) {
    EXPECT_NE(server::framingProblem(11, Lines{host}, false, false), "") << host;
  }
}

TEST(ServeHttpRules, CloseInAnyConnectionLineEndsTheConnection) {
  using Lines = std::vector<std::string_view>;
  EXPECT_TRUE(server::clientKeepsConnection(11, Lines{}));
  EXPECT_FALSE(server::clientKeepsConnection(10, Lines{}));
  EXPECT_TRUE(server::clientKeepsConnection(10, Lines{"Keep-Alive"}));
  EXPECT_FALSE(server::clientKeepsConnection(11, Lines{"keep-alive", "close"}));
  EXPECT_FALSE(server::clientKeepsConnection(10, Lines{"keep-alive, close"}));
  EXPECT_FALSE(server::clientKeepsConnection(11, Lines{"foo, CLOSE"}));
  EXPECT_TRUE(server::clientKeepsConnection(11, Lines{"closed, upgrade"}));
}

TEST(ServeHttpRules, EmptyLinesBeforeARequestLineAndItsVersion) {
  EXPECT_EQ(server::emptyLinesAtStart("GET / HTTP/1.1\r\n"), 0u);
  EXPECT_EQ(server::emptyLinesAtStart("\r\n\n\r\nGET"), 5u);
  EXPECT_EQ(server::emptyLinesAtStart("\r\n\r"), 2u) << "a CR whose LF has not come yet stays";
  EXPECT_EQ(server::emptyLinesAtStart(" \r\n"), 0u);

  using server::LineVersion;
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/1.1"), LineVersion::kAsItIs);
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/1.0"), LineVersion::kAsItIs);
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/1.2"), LineVersion::kLaterMinor);
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/1.9"), LineVersion::kLaterMinor);
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/2.0"), LineVersion::kOtherMajor);
  EXPECT_EQ(server::requestLineVersion("GET / HTTP/0.9"), LineVersion::kOtherMajor);
  // Other shapes are the parser's to refuse.
  for (const char* line : {"GET /", "GET / HTTP/1.10", "GET / HTTP/1.x", "GET / http/1.2", "HTTP/1.2", ""}) {
    EXPECT_EQ(server::requestLineVersion(line), LineVersion::kAsItIs) << line;
  }
}

TEST(ServeHttpRules, DatesAndMethods) {
  EXPECT_EQ(server::httpDate(784111777), "Sun, 06 Nov 1994 08:49:37 GMT");  // RFC 9110 5.6.7's example
  EXPECT_EQ(server::httpDate(0), "Thu, 01 Jan 1970 00:00:00 GMT");
  for (const char* method : {"GET", "HEAD", "POST", "PUT", "DELETE", "CONNECT", "OPTIONS", "TRACE", "PATCH"}) {
    EXPECT_TRUE(server::isStandardMethod(method)) << method;
  }
  for (const char* method : {"get", "BREW", "PROPFIND", ""}) EXPECT_FALSE(server::isStandardMethod(method)) << method;
}

// An answer's head, the Date line aside (checked against the clock in
// ServeVersions.AnswersCarryTheDate).
std::string headWithoutDate(unsigned version, const server::HttpReply& reply, std::size_t length, bool keep) {
  std::string head = server::responseHead(version, reply, length, keep);
  const std::size_t date = head.find("\r\nDate: ");
  if (date == std::string::npos) return "no Date: " + head;
  return head.erase(date + 2, head.find("\r\n", date + 2) - date);
}

TEST(ServeResponseHead, StatusFieldsLengthAndConnection) {
  server::HttpReply tile;
  tile.headers = {{"ETag", "\"x\""}, {"Cache-Control", "no-store"}};
  tile.content_type = "image/png";
  EXPECT_EQ(headWithoutDate(11, tile, 5, true),
            "HTTP/1.1 200 OK\r\nETag: \"x\"\r\nCache-Control: no-store\r\nContent-Type: image/png\r\n"
            "Content-Length: 5\r\n\r\n");
  EXPECT_EQ(headWithoutDate(11, tile, 5, false),
            "HTTP/1.1 200 OK\r\nETag: \"x\"\r\nCache-Control: no-store\r\nContent-Type: image/png\r\n"
            "Content-Length: 5\r\nConnection: close\r\n\r\n");
  // HTTP/1.0: answered as HTTP/1.1, saying that the connection stays or goes.
  EXPECT_NE(headWithoutDate(10, tile, 5, true).find("\r\nConnection: keep-alive\r\n\r\n"), std::string::npos);
  EXPECT_NE(headWithoutDate(10, tile, 5, false).find("\r\nConnection: close\r\n\r\n"), std::string::npos);
  // Without a body: no Content-Type, no Content-Length.
  for (const int status : {304, 204}) {
    server::HttpReply bodiless = tile;
    bodiless.status = status;
    const std::string head = headWithoutDate(11, bodiless, 5, true);
    EXPECT_EQ(head.find("Content-"), std::string::npos) << head;
  }
  server::HttpReply too_large;
  too_large.status = 413;
  EXPECT_EQ(headWithoutDate(11, too_large, 0, false),
            "HTTP/1.1 413 Content Too Large\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(server::reasonPhrase(414), "URI Too Long");
  EXPECT_EQ(server::reasonPhrase(501), "Not Implemented");
}

TEST(ServeHttpRules, SingleByteRanges) {
  using Kind = server::ByteRange::Kind;
  const auto range = [](const std::string& text, std::size_t length) { return server::parseRange(text, length); };
  const auto part = [](const server::ByteRange& r) { return std::to_string(r.first) + "-" + std::to_string(r.last); };
  EXPECT_EQ(part(range("bytes=0-9", 100)), "0-9");
  EXPECT_EQ(range("bytes=0-9", 100).kind, Kind::kPart);
  EXPECT_EQ(part(range("bytes=90-", 100)), "90-99");
  EXPECT_EQ(part(range("bytes=-10", 100)), "90-99");
  EXPECT_EQ(part(range("bytes=-1000", 100)), "0-99");
  EXPECT_EQ(part(range("bytes=50-5000", 100)), "50-99");
  EXPECT_EQ(part(range(" Bytes=3-4 ", 100)), "3-4");
  EXPECT_EQ(part(range("bytes=99-99", 100)), "99-99");
  // Positions of more digits than any length has: the end, or past it.
  EXPECT_EQ(part(range("bytes=0-99999999999999999999", 100)), "0-99");
  EXPECT_EQ(part(range("bytes=-99999999999999999999", 100)), "0-99");
  for (const char* past : {"bytes=100-", "bytes=100-200", "bytes=-0", "bytes=99999999999999999999-"}) {
    EXPECT_EQ(range(past, 100).kind, Kind::kUnsatisfiable) << past;
  }
  EXPECT_EQ(range("bytes=0-", 0).kind, Kind::kUnsatisfiable);
  EXPECT_EQ(range("bytes=-5", 0).kind, Kind::kUnsatisfiable);
  // Several ranges, other units, nonsense: the whole body.
  for (const char* whole : {"", "bytes=0-1,5-6", "items=0-1", "bytes=", "bytes=-", "bytes=a-b", "bytes=5-2",
                            "bytes=1-2-3", "bytes=+1-2", "0-9"}) {
    EXPECT_EQ(range(whole, 100).kind, Kind::kWhole) << whole;
  }
}

TEST(ServeHttpRules, IfRangeComparesStrongly) {
  EXPECT_TRUE(server::ifRangeHolds("\"abc-12\"", "\"abc-12\""));
  EXPECT_TRUE(server::ifRangeHolds(" \"abc-12\" ", "\"abc-12\""));
  EXPECT_FALSE(server::ifRangeHolds("W/\"abc-12\"", "\"abc-12\""));
  EXPECT_FALSE(server::ifRangeHolds("\"abc-13\"", "\"abc-12\""));
  EXPECT_FALSE(server::ifRangeHolds("Wed, 21 Oct 2015 07:28:00 GMT", "\"abc-12\""));
  EXPECT_FALSE(server::ifRangeHolds("", "\"abc-12\""));
}

// Generated bodies' tags: XXH3 64 in 16 hex digits, then the length in hex.
TEST(ServeHttpRules, ContentEtagsSpellHashAndLength) {
  EXPECT_EQ(server::contentEtag(""), "\"2d06800538d394c2-0\"");  // XXH3_64bits of no bytes, as xxHash's tests give it
  EXPECT_EQ(server::contentEtag("a"), "\"e6c632b61e964e1f-1\"");
  EXPECT_EQ(server::contentEtag(std::string(300, 'x')).substr(17), "-12c\"");
  std::string padded;
  appendHex(padded, 0x1f, 16);
  EXPECT_EQ(padded, "000000000000001f");
  appendHex(padded, 0);
  EXPECT_EQ(padded, "000000000000001f0");
}

// A file's tag: inode, size and modification time in nanoseconds, in hex.
TEST(ServedFiles, FileEtagsSpellInodeSizeAndTime) {
  const fs::path dir = caseDir();
  writeText(dir / "file.bin", std::string(26, 'z'));
  struct stat info {};
  ASSERT_EQ(::stat((dir / "file.bin").c_str(), &info), 0);
  const auto hex = [](unsigned long long value) {
    std::ostringstream text;
    text << std::hex << value;
    return text.str();
  };
  const unsigned long long mtime_ns =
      (unsigned long long)info.st_mtim.tv_sec * 1000000000ULL + (unsigned long long)info.st_mtim.tv_nsec;
  EXPECT_EQ(server::ServedFolder(dir.string()).etag("file.bin"),
            "\"" + hex(info.st_ino) + "-1a-" + hex(mtime_ns) + "\"");
}

TEST(ServedFiles, PartsOfAFileAreReadWhereAskedAndNowhereElse) {
  const fs::path dir = caseDir();
  writeText(dir / "file.bin", "0123456789");
  const server::ServedFolder folder(dir);
  const std::optional<server::OpenedFile> file = folder.open("file.bin");
  ASSERT_TRUE(file);
  EXPECT_EQ(file->size(), 10u);
  EXPECT_EQ(file->etag(), folder.etag("file.bin"));
  EXPECT_EQ(file->read(3, 4), "3456");
  EXPECT_EQ(file->read(0, 10), "0123456789");
  EXPECT_EQ(file->read(10, 0), "");
  EXPECT_FALSE(file->read(8, 3)) << "past the end";
  EXPECT_FALSE(file->read(11, 0));
  EXPECT_FALSE(file->read(std::size_t(-1), 2)) << "no overflow past the end";
  const std::optional<FileContent> whole = folder.read("file.bin");
  ASSERT_TRUE(whole);
  EXPECT_EQ(whole->bytes, "0123456789");
  EXPECT_EQ(whole->etag, file->etag());
  EXPECT_FALSE(folder.open("missing.bin"));
  EXPECT_FALSE(folder.open("../file.bin"));
  EXPECT_FALSE(folder.open("")) << "the folder itself is no file";
}

// The server (its connections) and tile (its workers' files) raise the
// soft limit as far as the hard one allows, and never lower it.
TEST(OpenFileLimit, IsRaisedAsFarAsTheHardLimitAllows) {
  rlimit before{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &before), 0);
  if (before.rlim_max != RLIM_INFINITY && before.rlim_max < 256) GTEST_SKIP() << "a hard limit under 256";
  rlimit lower = before;
  lower.rlim_cur = 64;
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &lower), 0);
  EXPECT_EQ(raiseOpenFileLimit(200), 200u);
  rlimit now{};
  ::getrlimit(RLIMIT_NOFILE, &now);
  EXPECT_EQ(now.rlim_cur, 200u);
  EXPECT_EQ(raiseOpenFileLimit(100), 200u) << "a higher limit stays";
  if (before.rlim_max != RLIM_INFINITY) {
    EXPECT_EQ(raiseOpenFileLimit(before.rlim_max + 1000), before.rlim_max);
  }
  ::setrlimit(RLIMIT_NOFILE, &before);
}

// A file that is there but cannot be opened now is no absent file (a 404 a
// cache would keep): the read throws, saying it may work later.
TEST(ServedFiles, AFileThatCannotBeOpenedNowIsNotAbsent) {
  const fs::path dir = caseDir();
  writeText(dir / "file.bin", "0123456789");
  const server::ServedFolder folder(dir);
  test::expectBusyWithAllFilesOpen([&] { folder.read("file.bin"); }, "file.bin");
  test::expectBusyWithAllFilesOpen([&] { folder.open("file.bin"); }, "file.bin");
  bool missing_found = true;
  {
    const AllFilesOpen taken;
    missing_found = folder.open("missing.bin").has_value();
  }
  EXPECT_FALSE(missing_found) << "an absent file is still absent";
}

TEST(ServeConfig, LimitsAndThePublicUrl) {
  const config::ServeConfig defaults;
  EXPECT_EQ(defaults.public_url, "");
  EXPECT_GE(defaults.max_connections, 1024) << "room for hundreds of idle clients beside the real ones";
  EXPECT_LE(defaults.read_timeout_s, 30);
  EXPECT_LE(defaults.idle_timeout_s, defaults.read_timeout_s);
  config::ServeConfig config;
  for (const char* url : {"https://tiles.example.org/", "http://127.0.0.1:8080", "https://a.example/b/c/", "http://[::1]:80/"}) {
    EXPECT_NO_THROW(config::applyOverride(config, "server.public_url", {url}, "--public-url")) << url;
    EXPECT_NO_THROW(config::validate(config, "test")) << url;
    EXPECT_EQ(config.public_url.rfind(url, 0), 0u) << url << " became " << config.public_url;
  }
  for (const char* url : {"tiles.example.org", "ftp://x/", "https://", "https://x/?q=1", "https://x/\"<script>",
                          "javascript:alert(1)"}) {
    EXPECT_THROW(config::applyOverride(config, "server.public_url", {url}, "--public-url"), UsageError) << url;
  }
  config = {};
  EXPECT_THROW(config::applyOverride(config, "http.max_connections", {"8"}, "test"), UsageError);
  config::applyOverride(config, "http.max_connections", {"20000"}, "test");
  EXPECT_EQ(config.max_connections, 20000);
}

TEST(ServeTileJson, ServedSourcesAreFileNamesOnly) {
  const std::string text = R"({"tilejson": "3.0.0", "tiles": ["./{z}/{x}/{y}.png"],
    "terrabake": {"mesh": "./{z}/{x}/{y}.glb", "sources": ["/srv/dems/alps.tif", "dems/*.hgt", "plain.tif"]}})";
  const std::string served = io::servedTileJson(text, "http://127.0.0.1:8080/alps/");
  EXPECT_EQ(served.find("/srv/dems"), std::string::npos) << served;
  const nlohmann::json doc = nlohmann::json::parse(served);
  EXPECT_EQ(doc["terrabake"]["sources"], nlohmann::json::array({"alps.tif", "*.hgt", "plain.tif"}));
  EXPECT_EQ(doc["tiles"][0], "http://127.0.0.1:8080/alps/{z}/{x}/{y}.png");
  // Whatever "sources" holds that terrabake never writes is not passed on.
  const std::string odd = io::servedTileJson(R"({"terrabake": {"sources": "/srv/dems/alps.tif"}})", "http://h/l/");
  EXPECT_EQ(odd.find("/srv/dems"), std::string::npos) << odd;
}

// --- The tile cache ----------------------------------------------------------

constexpr std::size_t kMib = 1024 * 1024;

std::shared_ptr<const FileContent> content(const std::string& bytes, const std::string& etag = "\"e\"") {
  return std::make_shared<const FileContent>(FileContent{bytes, etag});
}

const TileCache::IsCurrent kAlwaysCurrent = [](const FileContent&) { return true; };

TEST(TileCache, KeepsWithinItsBoundDroppingTheLeastRecentlyUsed) {
  const std::string bytes(1000, 'x');
  const std::size_t one = TileCache::entryBytes("a", *content(bytes));
  TileCache cache(3 * one + one / 2);  // room for three tiles, not four
  for (const char* key : {"a", "b", "c"}) cache.insert(key, content(bytes));
  EXPECT_EQ(cache.counters().tiles, 3u);
  ASSERT_TRUE(cache.find("a", kAlwaysCurrent));  // now the most recently used
  cache.insert("d", content(bytes));
  EXPECT_EQ(cache.counters().tiles, 3u);
  EXPECT_EQ(cache.counters().bytes, 3 * one);
  EXPECT_TRUE(cache.find("a", kAlwaysCurrent));
  EXPECT_FALSE(cache.find("b", kAlwaysCurrent)) << "the least recently used goes first";
  EXPECT_TRUE(cache.find("c", kAlwaysCurrent));
  EXPECT_TRUE(cache.find("d", kAlwaysCurrent));
  EXPECT_EQ(cache.counters().hits, 4u);
  EXPECT_EQ(cache.counters().misses, 1u);
}

TEST(TileCache, ATileLargerThanTheBoundIsNotKeptAndEvictsNothing) {
  TileCache cache(4096);
  cache.insert("small", content("s"));
  cache.insert("big", content(std::string(5000, 'x')));
  EXPECT_FALSE(cache.find("big", kAlwaysCurrent));
  EXPECT_TRUE(cache.find("small", kAlwaysCurrent));
  EXPECT_EQ(cache.counters().tiles, 1u);
}

TEST(TileCache, ReplacingATileCountsOnlyTheNewOne) {
  TileCache cache(kMib);
  cache.insert("a", content(std::string(100, 'x'), "\"1\""));
  cache.insert("a", content(std::string(300, 'y'), "\"2\""));
  const auto kept = cache.find("a", kAlwaysCurrent);
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->etag, "\"2\"");
  EXPECT_EQ(cache.counters().tiles, 1u);
  EXPECT_EQ(cache.counters().bytes, TileCache::entryBytes("a", *kept));
}

TEST(TileCache, AKeptTileThatIsNoLongerCurrentIsDropped) {
  TileCache cache(kMib);
  cache.insert("a", content("old"));
  EXPECT_FALSE(cache.find("a", [](const FileContent&) { return false; }));
  EXPECT_EQ(cache.counters().tiles, 0u);
  EXPECT_EQ(cache.counters().bytes, 0u);
  EXPECT_EQ(cache.counters().misses, 1u);
  EXPECT_FALSE(cache.find("a", kAlwaysCurrent));
}

// A state read again at every look while its files go on changing (a run
// writing into a served MBTiles file) says so once in the log, not once a
// look; after a look that finds no change, the next change is said again.
TEST(StoredState, ARunOfChangesIsLoggedOnce) {
  int version = 1;
  int reads = 0;
  const server::StoredState<int> state(
      "layer x", [&] { return std::optional<std::string>(std::to_string(version)); },
      [&] { return std::make_shared<const int>(++reads); });
  const auto lookAfterInterval = [&](int new_version) {
    std::this_thread::sleep_for(server::StoredState<int>::kLookInterval + std::chrono::milliseconds(50));
    version = new_version;
    testing::internal::CaptureStderr();
    const int read = *state.current();
    return std::make_pair(read, testing::internal::GetCapturedStderr());
  };
  const std::string said = "layer x changed: read again";
  auto [read, log] = lookAfterInterval(2);
  EXPECT_EQ(read, 2);
  EXPECT_NE(log.find(said), std::string::npos) << log;
  std::tie(read, log) = lookAfterInterval(3);
  EXPECT_EQ(read, 3) << "read again";
  EXPECT_EQ(log, "") << "the run of changes goes on";
  std::tie(read, log) = lookAfterInterval(3);
  EXPECT_EQ(read, 3);
  EXPECT_EQ(log, "");
  std::tie(read, log) = lookAfterInterval(4);
  EXPECT_EQ(read, 4);
  EXPECT_NE(log.find(said), std::string::npos) << "a new run of changes: " << log;
}

}  // namespace
}  // namespace terrabake
