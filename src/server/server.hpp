#pragma once
// `terrabake serve`: an HTTP server over a set of layers, from binding the
// port to a graceful stop. The HTTP library stays behind this header.
#include <memory>
#include <string>
#include <vector>

#include "config/serve_config.hpp"
#include "server/layer_set.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

class Server {
 public:
  // Binds http.bind:http.port (0: any free port). Throws InputError when it
  // cannot. `look_for_new`, when given, finds layers added later (LayerSet).
  Server(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
         LayerSet::LookForNew look_for_new = {});
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  int port() const;
  std::string url() const;  // "http://127.0.0.1:8080/"

  // Serves until stop(); returns once the requests in progress are answered.
  void run();

  // From any thread, any number of times, also before run() (which then
  // returns at once): stops accepting connections, abandons queued bakes
  // (their requests get 503), waits for running bakes to finish.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::server
