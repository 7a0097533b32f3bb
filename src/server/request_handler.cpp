#include "server/request_handler.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/log.hpp"
#include "io/layer_layout.hpp"
#include "server/http_rules.hpp"

namespace terrabake::server {
namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kAllowedMethods = "GET, HEAD, OPTIONS";
constexpr const char* kPreflightMaxAgeS = "86400";  // browsers cap it lower anyway
// The viewer and JSON change while the server runs: caches must ask each time
// (cheap: an unchanged file is a 304).
constexpr const char* kRevalidate = "no-cache";
constexpr const char* kNoStore = "no-store";
constexpr std::size_t kMib = 1024 * 1024;

HttpReply text(int status, const std::string& message) {
  HttpReply reply;
  reply.status = status;
  reply.content_type = "text/plain; charset=utf-8";
  reply.body = message + "\n";
  reply.headers.emplace_back("Cache-Control", kNoStore);
  return reply;
}

// A body of `length` bytes answered under `etag`: 412 when If-Match names
// another version, 304 when the client holds this very version, 416 for a
// range past the end (all `done`), else the
// headers of a 200 with the whole body, or of a 206 with the part a single
// Range asks for, and which bytes of the body to send.
struct Validation {
  HttpReply reply;
  bool done = false;
  std::size_t first = 0, count = 0;  // unless done: the bytes to send
};

Validation validate(const HttpRequest& request, std::size_t length, const std::string& etag,
                    const std::string& cache_control) {
  Validation v;
  v.reply.headers.emplace_back("ETag", etag);
  v.reply.headers.emplace_back("Cache-Control", cache_control);
  // If-Match first (RFC 9110 13.2.2): a range reader that asks for the
  // version it read before must not get bytes of another.
  if (!ifMatchHolds(request.if_match, etag)) {
    v.reply = text(412, "precondition failed: the body is no longer the version If-Match names");
    v.reply.headers.emplace_back("ETag", etag);
    v.done = true;
    return v;
  }
  // Then If-None-Match: a client holding the version wants no part of it.
  if (noneMatchHits(request.if_none_match, etag)) {
    // No body, and no Content-Length: the real length would make some clients wait for a body.
    v.reply.status = 304;
    v.done = true;
    return v;
  }
  v.reply.headers.emplace_back("Accept-Ranges", "bytes");
  // Ranges are for GET alone (RFC 9110 14.2): a HEAD is answered with the whole body's head.
  const bool range_applies = request.method == "GET" && !request.range.empty() &&
                             (request.if_range.empty() || ifRangeHolds(request.if_range, etag));
  const ByteRange range = range_applies ? parseRange(request.range, length) : ByteRange{};
  const std::string total = std::to_string(length);
  v.count = length;
  if (range.kind == ByteRange::Kind::kUnsatisfiable) {
    v.reply = text(416, "range not satisfiable: the body is " + total + " bytes");
    v.reply.headers.emplace_back("Content-Range", "bytes */" + total);
    v.done = true;
  } else if (range.kind == ByteRange::Kind::kPart) {
    v.reply.status = 206;
    v.reply.headers.emplace_back("Content-Range", "bytes " + std::to_string(range.first) + "-" +
                                                      std::to_string(range.last) + "/" + total);
    v.first = range.first;
    v.count = range.last - range.first + 1;
  }
  return v;
}

HttpReply validated(const HttpRequest& request, std::string content_type, std::string body, const std::string& etag,
                    const std::string& cache_control) {
  Validation v = validate(request, body.size(), etag, cache_control);
  if (v.done) return std::move(v.reply);
  if (v.count < body.size()) body = body.substr(v.first, v.count);
  v.reply.content_type = std::move(content_type);
  v.reply.body = std::move(body);
  return std::move(v.reply);
}

// The same for a tile in memory, which the connection sends from where it is.
HttpReply validatedMemory(const HttpRequest& request, std::string content_type,
                          std::shared_ptr<const FileContent> content, const std::string& cache_control) {
  Validation v = validate(request, content->bytes.size(), content->etag, cache_control);
  if (v.done) return std::move(v.reply);
  v.reply.content_type = std::move(content_type);
  v.reply.body = HttpReply::MemoryPart{std::move(content), v.first, v.count};
  return std::move(v.reply);
}

// The same for a file, which the connection reads as it sends the part.
HttpReply validatedFile(const HttpRequest& request, std::string content_type, OpenedFile file,
                        const std::string& cache_control) {
  Validation v = validate(request, file.size(), file.etag(), cache_control);
  if (v.done) return std::move(v.reply);
  v.reply.content_type = std::move(content_type);
  v.reply.body = HttpReply::FilePart{std::make_shared<const OpenedFile>(std::move(file)), v.first, v.count};
  return std::move(v.reply);
}

HttpReply staticFile(const HttpRequest& request, const ServedFolder& folder, const std::string& file) {
  std::optional<OpenedFile> opened = folder.open(file);
  if (!opened) return text(404, "not found: no such file");
  return validatedFile(request, contentTypeFor(file), std::move(*opened), kRevalidate);
}

const char* contentTypeOf(io::TileFormat format) {
  const bool image = format == io::TileFormat::kPng || format == io::TileFormat::kElevationPng;
  return image ? "image/png" : "model/gltf-binary";
}

// Every answer carries these, errors included.
void finish(HttpReply& reply) {
  // So browser viewers on other origins can read tiles (nothing served names a local path).
  reply.headers.emplace_back("Access-Control-Allow-Origin", "*");
  reply.headers.emplace_back("Access-Control-Expose-Headers", "ETag, Retry-After, Content-Range, Accept-Ranges");
  reply.headers.emplace_back("X-Content-Type-Options", "nosniff");
}

}  // namespace

RequestHandler::RequestHandler(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
                               LayerSet::LookForNew look_for_new)
    : m_layers(std::move(layers), std::move(look_for_new)),
      m_viewer(config.viewer_dir),
      m_public_url(config.public_url.empty() || config.public_url.back() == '/' ? config.public_url
                                                                                 : config.public_url + "/"),
      m_tile_cache_control("public, max-age=" + std::to_string(config.tile_max_age_s)),
      m_retry_after_s(std::to_string(config.retry_after_s)),
      m_tile_cache(config.cache_mib > 0 ? std::make_unique<TileCache>(std::size_t(config.cache_mib) * kMib) : nullptr) {
  for (const VendorPackage& package : vendorPackages()) {
    m_vendor.emplace(package.name, ServedFolder(std::filesystem::path(config.viewer_dir) / "node_modules" / package.folder));
  }
}

void RequestHandler::stopLayers() {
  for (LayerSource* layer : m_layers.held()) layer->stop();
}

void RequestHandler::handle(const HttpRequest& request, const Respond& respond) const {
  HttpReply reply;
  if (request.method != "GET" && request.method != "HEAD" && request.method != "OPTIONS") {
    // Decided on the request line and headers alone: a body is never read.
    // A method HTTP defines is not allowed here; any other is not known (RFC 9110 9.1).
    if (isStandardMethod(request.method)) {
      reply = text(405, "method not allowed: " + request.method);
      reply.headers.emplace_back("Allow", kAllowedMethods);
    } else {
      reply = text(501, "not implemented: no method " + request.method);
    }
  } else if (request.has_body) {
    reply = text(413, "content too large: no request here takes a body");
  } else if (request.method == "OPTIONS") {
    // A CORS preflight: say yes to reading anything, for any origin.
    reply.status = 204;
    reply.headers.emplace_back("Access-Control-Allow-Methods", kAllowedMethods);
    if (!request.cors_request_headers.empty() && isHeaderNameList(request.cors_request_headers)) {
      reply.headers.emplace_back("Access-Control-Allow-Headers", request.cors_request_headers);
    }
    reply.headers.emplace_back("Access-Control-Max-Age", kPreflightMaxAgeS);
  } else {
    try {
      const Route route = parseRoute(request.path);
      LayerSource* const layer = route.kind == Route::Kind::kTile ? m_layers.find(route.layer) : nullptr;
      if (!layer) {
        reply = answerNow(request, route);
      } else {
        LayerSource& source = *layer;
        const bool cached = m_tile_cache && source.tilesMayBeKept();
        const std::string key = cached ? route.layer + "/" + io::relativeTilePath(route.tile, route.format) : "";
        if (cached) {
          const std::shared_ptr<const FileContent> kept = m_tile_cache->find(
              key, [&](const FileContent& content) { return source.isCurrent(route.tile, route.format, content); });
          if (kept) {
            reply = fromTile(request, route, {TileAnswer::Status::kFound, kept, {}});
            finish(reply);
            return respond(std::move(reply));
          }
        }
        // The answer may need a bake: then it comes later, from the bake worker,
        // and this thread goes on to other requests.
        const auto waiting = std::make_shared<const HttpRequest>(request);
        const LayerSource::Later later = [this, waiting, route, respond, &source, key](TileAnswer answer) {
          HttpReply late;
          try {
            keep(source, key, answer, true);
            late = fromTile(*waiting, route, answer);
          } catch (const std::exception& e) {
            // The request must be answered: it waits with no timeout of its own.
            late = text(500, "tile " + route.tile.str() + ": " + oneLine(e.what()));
          }
          finish(late);
          respond(std::move(late));
        };
        const TileAnswer answer = source.tile(route.tile, route.format, later);
        if (answer.status == TileAnswer::Status::kPending) return;
        keep(source, key, answer, false);
        reply = fromTile(request, route, answer);
      }
    } catch (const UnreadableFile& e) {
      reply = unreadable(request, e);
    }
  }
  finish(reply);
  respond(std::move(reply));
}

HttpReply RequestHandler::unreadable(const HttpRequest& request, const UnreadableFile& error) const {
  if (error.temporary) {
    // Short of open files (many connections) or memory: answered at once,
    // never as a 404 a cache would keep.
    HttpReply reply = text(503, "busy: the server cannot open files now");
    reply.headers.emplace_back("Retry-After", m_retry_after_s);
    return reply;
  }
  log::error(request.method + " " + request.path + ": " + oneLine(error.what()));
  return text(500, "the file could not be read (the server's log says why)");
}

HttpReply RequestHandler::refusal(int status, const std::string& message) const {
  HttpReply reply = text(status, message);
  if (status == 503) reply.headers.emplace_back("Retry-After", m_retry_after_s);
  finish(reply);
  return reply;
}

std::string RequestHandler::baseUrl(const HttpRequest& request) const {
  // Never from the Host header: a forged one would point the URLs, and every
  // cache keeping the answer, elsewhere.
  return m_public_url.empty() ? "http://" + request.local_address + "/" : m_public_url;
}

HttpReply RequestHandler::answerNow(const HttpRequest& request, const Route& route) const {
  switch (route.kind) {
    case Route::Kind::kViewerPage:
      return staticFile(request, m_viewer, "index.html");
    case Route::Kind::kViewerFile:
      return staticFile(request, m_viewer, route.file);
    case Route::Kind::kVendorFile:
      return staticFile(request, m_vendor.at(route.package), route.file);
    case Route::Kind::kLayerList:
      return layerList(request);
    case Route::Kind::kHealth:
      return health();
    case Route::Kind::kTileJson: {
      LayerSource* const layer = m_layers.find(route.layer);
      if (!layer) return text(404, "not found: no layer '" + route.layer + "'");
      std::string body = layer->tileJson(baseUrl(request) + route.layer + "/");
      const std::string etag = contentEtag(body);
      return validated(request, "application/json", std::move(body), etag, kRevalidate);
    }
    case Route::Kind::kTileset: {
      LayerSource* const layer = m_layers.find(route.layer);
      if (!layer) return text(404, "not found: no layer '" + route.layer + "'");
      std::optional<FileContent> content = layer->tilesetFile(route.file);
      if (!content) {
        return text(404, "not found: layer '" + route.layer + "' has no " + route.file +
                             " (a layer has one when its job sets output.tileset: true; for an on-demand layer "
                             "whose tiles cannot be planned, the server's log says why)");
      }
      return validated(request, "application/json", std::move(content->bytes), content->etag, m_tile_cache_control);
    }
    case Route::Kind::kArchive: {
      LayerSource* const layer = m_layers.find(route.layer);
      if (!layer) return text(404, "not found: no layer '" + route.layer + "'");
      std::optional<OpenedFile> archive = layer->archive(route.file);
      if (!archive) return text(404, "not found: layer '" + route.layer + "' is stored in no archive " + route.file);
      return validatedFile(request, contentTypeFor(route.file), std::move(*archive), m_tile_cache_control);
    }
    case Route::Kind::kElevationTileJson: {
      LayerSource* const layer = m_layers.find(route.layer);
      if (!layer) return text(404, "not found: no layer '" + route.layer + "'");
      std::optional<std::string> body = layer->elevationTileJson(baseUrl(request) + route.layer + "/");
      if (!body) return text(404, "not found: layer '" + route.layer + "' has no elevation tiles");
      const std::string etag = contentEtag(*body);
      return validated(request, "application/json", std::move(*body), etag, kRevalidate);
    }
    case Route::Kind::kTile:
      return text(404, "not found: no layer '" + route.layer + "'");
    case Route::Kind::kBadRequest:
      return text(400, "bad request: " + route.problem);
    case Route::Kind::kNotFound:
      break;
  }
  return text(404, "not found: " + route.problem);
}

HttpReply RequestHandler::fromTile(const HttpRequest& request, const Route& route, const TileAnswer& answer) const {
  switch (answer.status) {
    case TileAnswer::Status::kFound:
      return validatedMemory(request, contentTypeOf(route.format), answer.content, m_tile_cache_control);
    case TileAnswer::Status::kBusy: {
      HttpReply reply = text(503, "busy: " + answer.reason);
      reply.headers.emplace_back("Retry-After", m_retry_after_s);
      return reply;
    }
    case TileAnswer::Status::kFailed:
      return text(500, "tile " + route.tile.str() + ": " + answer.reason);
    case TileAnswer::Status::kPending:  // not an answer: the layer broke its promise
      return text(500, "tile " + route.tile.str() + ": no answer from the layer");
    case TileAnswer::Status::kNotFound:
      break;
  }
  return text(404, "not found: tile " + route.tile.str() + ": " + answer.reason);
}

void RequestHandler::keep(const LayerSource& layer, const std::string& key, const TileAnswer& answer,
                          bool from_bake) const {
  if (!m_tile_cache || !layer.tilesMayBeKept() || answer.status != TileAnswer::Status::kFound) return;
  // A bake's answer shares the whole baked tile (every format): the cache
  // keeps a copy of this one file, so that it holds no more than it counts.
  m_tile_cache->insert(key, from_bake ? std::make_shared<const FileContent>(*answer.content) : answer.content);
}

HttpReply RequestHandler::layerList(const HttpRequest& request) const {
  const std::string base_url = baseUrl(request);
  Json list = Json::array();
  for (const auto& [name, layer] : m_layers.all()) {
    list.push_back({{"name", name},
                    {"tilejson", base_url + name + "/" + io::kTileJsonFile},
                    {"on_demand", layer->bakesOnDemand()}});
  }
  std::string body = Json{{"layers", list}}.dump(2) + "\n";
  const std::string etag = contentEtag(body);
  return validated(request, "application/json", std::move(body), etag, kRevalidate);
}

HttpReply RequestHandler::health() const {
  BakeCounters total;
  const std::vector<LayerSource*> layers = m_layers.held();
  for (const LayerSource* layer : layers) {
    const BakeCounters c = layer->bakeCounters();
    total.started += c.started;
    total.joined += c.joined;
    total.written += c.written;
    total.empty += c.empty;
    total.failed += c.failed;
    total.rejected += c.rejected;
    total.waiting += c.waiting;
  }
  const TileCacheCounters cache = m_tile_cache ? m_tile_cache->counters() : TileCacheCounters{};
  HttpReply reply;
  reply.content_type = "application/json";
  reply.body = Json{{"status", "ok"},
                    {"layers", std::count_if(layers.begin(), layers.end(),
                                             [](const LayerSource* layer) { return !layer->isGone(); })},
                    {"bakes_started", total.started},
                    {"bakes_joined", total.joined},
                    {"bakes_written", total.written},
                    {"bakes_empty", total.empty},
                    {"bakes_failed", total.failed},
                    {"bakes_rejected", total.rejected},
                    {"bakes_waiting", total.waiting},
                    {"tile_cache_bytes", cache.bytes},
                    {"tile_cache_tiles", cache.tiles},
                    {"tile_cache_hits", cache.hits},
                    {"tile_cache_misses", cache.misses}}
                   .dump() +
               "\n";
  reply.headers.emplace_back("Cache-Control", kNoStore);
  return reply;
}

}  // namespace terrabake::server
