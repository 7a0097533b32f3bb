#pragma once
// Answers requests: routes, status codes, caching and CORS headers, in plain
// structs, so HTTP behaviour is decided here and the HTTP library only moves
// bytes (server.cpp).
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_source.hpp"
#include "server/route.hpp"
#include "server/served_folder.hpp"

namespace terrabake::server {

struct HttpRequest {
  std::string method;
  std::string path;           // percent-decoded, without the query
  std::string host;           // the Host header; "" when absent
  std::string local_address;  // "127.0.0.1:8080": used when Host is absent or unusable
  std::string if_none_match;
  std::string cors_request_headers;  // Access-Control-Request-Headers of a preflight
};

struct HttpReply {
  int status = 200;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string content_type;  // with body; "" when there is none
  std::string body;          // HEAD: the server leaves it out, Content-Length stays
};

class RequestHandler {
 public:
  RequestHandler(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers);

  // Called from many HTTP threads at once.
  HttpReply handle(const HttpRequest& request) const;

  // Stops every layer's background work (LayerSource::stop).
  void stopLayers();

 private:
  HttpReply answerGet(const HttpRequest& request, const Route& route) const;
  HttpReply tile(const HttpRequest& request, const Route& route) const;
  HttpReply layerList(const HttpRequest& request) const;
  HttpReply health() const;

  std::map<std::string, std::unique_ptr<LayerSource>> m_layers;
  ServedFolder m_viewer;
  ServedFolder m_three;
  std::string m_tile_cache_control;
  std::string m_retry_after_s;
};

}  // namespace terrabake::server
