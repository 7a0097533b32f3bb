#pragma once
// Answers requests: routes, status codes, ranges, caching and CORS headers, in
// plain structs, so HTTP behaviour is decided here and the HTTP library only
// moves bytes and enforces the connection limits (server.cpp).
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_set.hpp"
#include "server/layer_source.hpp"
#include "server/route.hpp"
#include "server/served_folder.hpp"
#include "server/tile_cache.hpp"

namespace terrabake::server {

struct HttpRequest {
  std::string method;
  std::string path;           // percent-decoded, without the query
  std::string local_address;  // "127.0.0.1:8080", where the client reached us: the base of URLs without a public_url
  std::string if_match;
  std::string if_none_match;
  std::string range;     // the Range header
  std::string if_range;  // the If-Range header
  std::string cors_request_headers;  // Access-Control-Request-Headers of a preflight
  bool has_body = false;  // a Content-Length above 0 or a chunked body, which is never read
};

struct HttpReply {
  int status = 200;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string content_type;  // with a body; "" when there is none
  // `length` bytes of `file` from `first`, read piece by piece as the
  // connection sends them, so a file of any size costs a piece of memory.
  struct FilePart {
    std::shared_ptr<const OpenedFile> file;
    std::size_t first = 0, length = 0;
  };
  // `length` bytes from `first` of a tile held in memory, shared with the
  // tile cache and the layer, not copied.
  struct MemoryPart {
    std::shared_ptr<const FileContent> content;
    std::size_t first = 0, length = 0;
  };
  using Body = std::variant<std::string, FilePart, MemoryPart>;
  // HEAD: the server leaves the body out, Content-Length stays.
  Body body;
};

class RequestHandler {
 public:
  // Receives the answer to one request, exactly once.
  using Respond = std::function<void(HttpReply)>;

  // `look_for_new`, when given, finds layers added to the tiles folder later.
  RequestHandler(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
                 LayerSet::LookForNew look_for_new = {});

  // Called from many HTTP threads at once, never waits for a bake: calls
  // `respond` before it returns, or, for a tile a bake is making, later from
  // the bake worker that made it (or from the thread that stops the layers).
  void handle(const HttpRequest& request, const Respond& respond) const;

  // The answer to a request the server refuses before it reaches handle():
  // 400 (unparseable), 408 (too slow), 431 (headers too large), 503 (too many
  // connections), with the headers every answer carries.
  HttpReply refusal(int status, const std::string& message) const;

  // Stops every layer's background work (LayerSource::stop).
  void stopLayers();

 private:
  HttpReply answerNow(const HttpRequest& request, const Route& route) const;
  HttpReply fromTile(const HttpRequest& request, const Route& route, const TileAnswer& answer) const;
  // 503 for a file the server is short of resources to read, else 500 (logged).
  HttpReply unreadable(const HttpRequest& request, const UnreadableFile& error) const;
  // Keeps a found tile of a layer that allows it, when the cache is on;
  // `from_bake`: the answer a bake handed to LayerSource::Later.
  void keep(const LayerSource& layer, const std::string& key, const TileAnswer& answer, bool from_bake) const;
  HttpReply layerList(const HttpRequest& request) const;
  HttpReply health() const;
  std::string baseUrl(const HttpRequest& request) const;

  LayerSet m_layers;
  ServedFolder m_viewer;
  std::map<std::string, ServedFolder> m_vendor;  // by package name (vendorPackages())
  std::string m_public_url;  // ending in '/'; "" when not set
  std::string m_tile_cache_control;
  std::string m_retry_after_s;
  std::unique_ptr<TileCache> m_tile_cache;  // null with http.cache_mib 0
};

}  // namespace terrabake::server
