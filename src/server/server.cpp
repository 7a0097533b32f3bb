#include "server/server.hpp"

#include <httplib.h>
#include <sys/socket.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <thread>

#include "core/error.hpp"
#include "core/log.hpp"
#include "server/request_handler.hpp"

namespace terrabake::server {
namespace {

// httplib's stop() waits for idle keep-alive connections to time out: keep
// that short so a stopping server exits within a couple of seconds.
constexpr time_t kKeepAliveTimeoutS = 2;
// Every path, newlines included (%0A decodes to one): our router decides.
constexpr const char* kAnyPath = R"([\s\S]*)";

// "host:port", with brackets around an IPv6 address.
std::string hostPort(const std::string& host, int port) {
  const bool ipv6 = host.find(':') != std::string::npos;
  return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

}  // namespace

struct Server::Impl {
  RequestHandler handler;
  httplib::Server http;
  std::string bind;
  int port = 0;
  // run() and stop() meet through these two (see stop()).
  std::atomic<bool> stopping{false};
  std::atomic<bool> in_run{false};

  Impl(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers)
      : handler(config, std::move(layers)), bind(config.bind) {
    const int threads = config.threads;
    http.new_task_queue = [threads] { return new httplib::ThreadPool(std::size_t(threads)); };
    http.set_keep_alive_timeout(kKeepAliveTimeoutS);
    // The keep-alive limit stays httplib's 5 requests a connection: with a
    // thread per connection, longer-lived ones starve those queued behind them
    // (measured with 32 connections on 8 threads: p99 200 ms at 50, 13 ms at 5).
    // httplib writes headers and body separately: without this, Nagle's
    // algorithm and delayed ACKs hold every response back about 40 ms.
    http.set_tcp_nodelay(true);
    // httplib's default adds SO_REUSEPORT, with which a second server binds a
    // port in use and silently takes half its connections: a busy port must
    // be an error. SO_REUSEADDR alone still allows a quick restart.
    http.set_socket_options([](socket_t socket) {
      const int yes = 1;
      ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    const auto serve = [this](const httplib::Request& request, httplib::Response& response) {
      answer(request, response);
    };
    http.Get(kAnyPath, serve);  // also HEAD: httplib answers it from GET and drops the body
    http.Options(kAnyPath, serve);
    http.Post(kAnyPath, serve);
    http.Put(kAnyPath, serve);
    http.Patch(kAnyPath, serve);
    http.Delete(kAnyPath, serve);
    http.set_exception_handler([](const httplib::Request& request, httplib::Response& response, std::exception_ptr e) {
      std::string what = "unknown error";
      try {
        std::rethrow_exception(e);
      } catch (const std::exception& error) {
        what = error.what();
      } catch (...) {
      }
      log::error(request.method + " " + request.path + ": " + oneLine(what));
      response.status = 500;
      response.set_content("internal error\n", "text/plain; charset=utf-8");
      response.set_header("Access-Control-Allow-Origin", "*");
    });

    errno = 0;
    port = config.port == 0 ? http.bind_to_any_port(config.bind)
                            : (http.bind_to_port(config.bind, config.port) ? config.port : -1);
    if (port < 0) {
      const int error = errno;
      throw InputError("http: cannot listen on " + hostPort(config.bind, config.port) + ": " +
                       (error ? std::strerror(error) : "not an address of this machine"));
    }
  }

  void answer(const httplib::Request& request, httplib::Response& response) const {
    HttpRequest in;
    in.method = request.method;
    in.path = request.path;
    in.host = request.get_header_value("Host");
    in.local_address = hostPort(request.local_addr, request.local_port);
    in.if_none_match = request.get_header_value("If-None-Match");
    in.cors_request_headers = request.get_header_value("Access-Control-Request-Headers");
    HttpReply out = handler.handle(in);
    response.status = out.status;
    for (const auto& [name, value] : out.headers) response.set_header(name, value);
    if (!out.content_type.empty()) {
      response.set_header("Content-Type", out.content_type);
      response.body = std::move(out.body);
    }
  }
};

Server::Server(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers)
    : m_impl(std::make_unique<Impl>(config, std::move(layers))) {}

Server::~Server() { m_impl->handler.stopLayers(); }

int Server::port() const { return m_impl->port; }

std::string Server::url() const { return "http://" + hostPort(m_impl->bind, m_impl->port) + "/"; }

void Server::run() {
  m_impl->in_run = true;
  if (!m_impl->stopping) m_impl->http.listen_after_bind();
  m_impl->in_run = false;
}

void Server::stop() {
  m_impl->stopping = true;
  // httplib's stop() does nothing until listen has begun, so wait for that
  // when run() is on its way in; run() sees `stopping` otherwise.
  while (m_impl->in_run && !m_impl->http.is_running()) std::this_thread::yield();
  m_impl->http.stop();
  m_impl->handler.stopLayers();
}

}  // namespace terrabake::server
