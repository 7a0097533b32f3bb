#include "server/request_handler.hpp"

#include <filesystem>

#include <nlohmann/json.hpp>

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

HttpReply text(int status, const std::string& message) {
  HttpReply reply;
  reply.status = status;
  reply.content_type = "text/plain; charset=utf-8";
  reply.body = message + "\n";
  reply.headers.emplace_back("Cache-Control", kNoStore);
  return reply;
}

// 200 with the body, or 304 when the client holds this very version.
HttpReply validated(const HttpRequest& request, std::string content_type, std::string body, const std::string& etag,
                    const std::string& cache_control) {
  HttpReply reply;
  reply.headers.emplace_back("ETag", etag);
  reply.headers.emplace_back("Cache-Control", cache_control);
  if (noneMatchHits(request.if_none_match, etag)) {
    // No body. httplib adds "Content-Length: 0", which caches ignore on a 304
    // (RFC 9111 3.2); the real length would make some clients wait for a body.
    reply.status = 304;
    return reply;
  }
  reply.content_type = std::move(content_type);
  reply.body = std::move(body);
  return reply;
}

HttpReply staticFile(const HttpRequest& request, const ServedFolder& folder, const std::string& file) {
  std::optional<FileContent> content = folder.read(file);
  if (!content) return text(404, "not found: no such file");
  return validated(request, contentTypeFor(file), std::move(content->bytes), content->etag, kRevalidate);
}

const char* contentTypeOf(io::TileFormat format) { return format == io::TileFormat::kPng ? "image/png" : "model/gltf-binary"; }

// "http://host:port/" as the client reached us.
std::string baseUrl(const HttpRequest& request) {
  return "http://" + (isPlausibleHost(request.host) ? request.host : request.local_address) + "/";
}

}  // namespace

RequestHandler::RequestHandler(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers)
    : m_viewer(config.viewer_dir),
      m_three(std::filesystem::path(config.viewer_dir) / "node_modules" / "three"),
      m_tile_cache_control("public, max-age=" + std::to_string(config.tile_max_age_s)),
      m_retry_after_s(std::to_string(config.retry_after_s)) {
  for (auto& layer : layers) {
    const std::string name = layer->name();
    m_layers.emplace(name, std::move(layer));
  }
}

void RequestHandler::stopLayers() {
  for (auto& [name, layer] : m_layers) layer->stop();
}

HttpReply RequestHandler::handle(const HttpRequest& request) const {
  HttpReply reply;
  if (request.method == "OPTIONS") {
    // A CORS preflight: say yes to reading anything, for any origin.
    reply.status = 204;
    reply.headers.emplace_back("Access-Control-Allow-Methods", kAllowedMethods);
    if (!request.cors_request_headers.empty() && isHeaderNameList(request.cors_request_headers)) {
      reply.headers.emplace_back("Access-Control-Allow-Headers", request.cors_request_headers);
    }
    reply.headers.emplace_back("Access-Control-Max-Age", kPreflightMaxAgeS);
  } else if (request.method == "GET" || request.method == "HEAD") {
    reply = answerGet(request, parseRoute(request.path));
  } else {
    reply = text(405, "method not allowed: " + request.method);
    reply.headers.emplace_back("Allow", kAllowedMethods);
  }
  // Every answer, errors included, so browser viewers on other origins can read them.
  reply.headers.emplace_back("Access-Control-Allow-Origin", "*");
  reply.headers.emplace_back("Access-Control-Expose-Headers", "ETag, Retry-After");
  reply.headers.emplace_back("X-Content-Type-Options", "nosniff");
  return reply;
}

HttpReply RequestHandler::answerGet(const HttpRequest& request, const Route& route) const {
  switch (route.kind) {
    case Route::Kind::kViewerPage:
      return staticFile(request, m_viewer, "index.html");
    case Route::Kind::kViewerFile:
      return staticFile(request, m_viewer, route.file);
    case Route::Kind::kVendorFile:
      return staticFile(request, m_three, route.file);
    case Route::Kind::kLayerList:
      return layerList(request);
    case Route::Kind::kHealth:
      return health();
    case Route::Kind::kTileJson: {
      const auto layer = m_layers.find(route.layer);
      if (layer == m_layers.end()) return text(404, "not found: no layer '" + route.layer + "'");
      std::string body = layer->second->tileJson(baseUrl(request) + route.layer + "/");
      const std::string etag = contentEtag(body);
      return validated(request, "application/json", std::move(body), etag, kRevalidate);
    }
    case Route::Kind::kTile:
      return tile(request, route);
    case Route::Kind::kBadRequest:
      return text(400, "bad request: " + route.problem);
    case Route::Kind::kNotFound:
      break;
  }
  return text(404, "not found: " + route.problem);
}

HttpReply RequestHandler::tile(const HttpRequest& request, const Route& route) const {
  const auto layer = m_layers.find(route.layer);
  if (layer == m_layers.end()) return text(404, "not found: no layer '" + route.layer + "'");
  const TileAnswer answer = layer->second->tile(route.tile, route.format);
  switch (answer.status) {
    case TileAnswer::Status::kFound:
      return validated(request, contentTypeOf(route.format), answer.content->bytes, answer.content->etag,
                       m_tile_cache_control);
    case TileAnswer::Status::kBusy: {
      HttpReply reply = text(503, "busy: " + answer.reason);
      reply.headers.emplace_back("Retry-After", m_retry_after_s);
      return reply;
    }
    case TileAnswer::Status::kFailed:
      return text(500, "tile " + route.tile.str() + ": " + answer.reason);
    case TileAnswer::Status::kNotFound:
      break;
  }
  return text(404, "not found: tile " + route.tile.str() + ": " + answer.reason);
}

HttpReply RequestHandler::layerList(const HttpRequest& request) const {
  const std::string base_url = baseUrl(request);
  Json list = Json::array();
  for (const auto& [name, layer] : m_layers) {
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
  for (const auto& [name, layer] : m_layers) {
    const BakeCounters c = layer->bakeCounters();
    total.started += c.started;
    total.joined += c.joined;
    total.written += c.written;
    total.empty += c.empty;
    total.failed += c.failed;
    total.rejected += c.rejected;
    total.waiting += c.waiting;
  }
  HttpReply reply;
  reply.content_type = "application/json";
  reply.body = Json{{"status", "ok"},
                    {"layers", m_layers.size()},
                    {"bakes_started", total.started},
                    {"bakes_joined", total.joined},
                    {"bakes_written", total.written},
                    {"bakes_empty", total.empty},
                    {"bakes_failed", total.failed},
                    {"bakes_rejected", total.rejected},
                    {"bakes_waiting", total.waiting}}
                   .dump() +
               "\n";
  reply.headers.emplace_back("Cache-Control", kNoStore);
  return reply;
}

}  // namespace terrabake::server
