#include "server/server.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>
#include <unordered_map>
#include <variant>
#include <vector>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/open_files.hpp"
#include "core/threads.hpp"
#include "core/usable_cores.hpp"
#include "server/http_rules.hpp"
#include "server/request_handler.hpp"
#include "server/response_head.hpp"

namespace terrabake::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
// A connection's socket and stream name their io_context's executor type:
// the type-erased default would copy and destroy an executor object in
// every handler.
using Socket = tcp::socket::rebind_executor<net::io_context::executor_type>::other;
using Stream = beast::basic_stream<tcp, net::io_context::executor_type, beast::unlimited_rate_policy>;

// After an answer on a connection that is not kept (a request body not read,
// Connection: close), the connection is closed once the client closes its
// side; until then, for at most this long and this many bytes, what the
// client still sends is read and dropped, so the close does not reset the
// connection before the client has read the answer.
constexpr auto kLingerTime = std::chrono::seconds(1);
constexpr std::size_t kLingerBytes = 256 * 1024;
// A failed accept (out of file descriptors) is tried again after this pause.
constexpr auto kAcceptRetry = std::chrono::milliseconds(50);
// File descriptors beyond the connections: layers, GDAL, MBTiles, logs.
constexpr std::size_t kSpareFiles = 256;

// "host:port", with brackets around an IPv6 address.
std::string hostPort(const std::string& host, int port) {
  const bool ipv6 = host.find(':') != std::string::npos;
  return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

// Runs `context` until it has no more work; a handler that throws is logged
// and the thread goes on serving.
void runContext(net::io_context& context) {
  for (int failures = 0; failures < 1000000; ++failures) {
    try {
      context.run();
      return;
    } catch (const std::exception& e) {
      log::error("http: " + oneLine(e.what()));
    }
  }
}

std::vector<std::unique_ptr<net::io_context>> makeContexts(int count) {
  std::vector<std::unique_ptr<net::io_context>> contexts;
  for (int i = 0; i < count; ++i) contexts.push_back(std::make_unique<net::io_context>(1));
  return contexts;
}

// Lets the process keep `connections` sockets open, as far as the hard limit allows.
void raiseFileLimit(int connections) {
  const std::size_t limit = raiseOpenFileLimit(std::size_t(connections) + kSpareFiles);
  if (limit < std::size_t(connections) + kSpareFiles) {
    log::warning("http: at most " + std::to_string(limit) + " open files (ulimit -n): fewer than " +
                 std::to_string(connections) + " connections may be served");
  }
}

// How much of a file a connection reads at a time while sending it.
constexpr std::size_t kFilePieceBytes = 64 * 1024;

// The values of every field line of `field` in a request head.
template <class Fields>
std::vector<std::string_view> fieldLines(const Fields& fields, http::field field) {
  std::vector<std::string_view> lines;
  for (auto [line, end] = fields.equal_range(field); line != end; ++line) {
    lines.emplace_back(line->value().data(), line->value().size());
  }
  return lines;
}

// A list field's value: its field lines joined, as one line (RFC 9110 5.3).
template <class Fields>
std::string listField(const Fields& fields, http::field field) {
  std::string list;
  for (const std::string_view line : fieldLines(fields, field)) list += (list.empty() ? "" : ", ") + std::string(line);
  return list;
}

std::size_t bodyLength(const HttpReply::Body& body) {
  return std::visit(
      [](const auto& part) -> std::size_t {
        if constexpr (std::is_same_v<std::decay_t<decltype(part)>, std::string>) {
          return part.size();
        } else {
          return part.length;
        }
      },
      body);
}

// An answer on its way out: its head, then its body a piece at a time (a
// file's read as it goes, a string's or a tile's in memory in one piece).
class Outgoing {
 public:
  // `send_body` false: HEAD, whose answer is the head alone.
  Outgoing(std::string head, HttpReply::Body body, bool send_body)
      : m_head(std::move(head)), m_body(std::move(body)), m_left(send_body ? bodyLength(m_body) : 0) {}

  bool started() const { return m_head_written > 0; }
  bool done() const { return m_head_written == m_head.size() && m_piece_written == m_piece.size() && m_left == 0; }

  // What to write next: what is left of the head and of the body's current
  // piece, taking the next piece once that one is written; none when the
  // file it comes from could not be read.
  std::optional<std::array<net::const_buffer, 2>> unwritten() {
    if (m_piece_written == m_piece.size() && m_left > 0) {
      const std::optional<net::const_buffer> piece =
          std::visit([this](const auto& part) { return pieceOf(part); }, m_body);
      if (!piece) return std::nullopt;
      m_piece = *piece;
      m_piece_written = 0;
      m_left -= m_piece.size();
    }
    return std::array<net::const_buffer, 2>{net::buffer(m_head) + m_head_written, m_piece + m_piece_written};
  }

  // After a write took `bytes` of unwritten(): the head's first.
  void wrote(std::size_t bytes) {
    const std::size_t of_head = std::min(bytes, m_head.size() - m_head_written);
    m_head_written += of_head;
    m_piece_written += bytes - of_head;
  }

 private:
  // Where the next piece starts in the body.
  std::size_t offset() const { return bodyLength(m_body) - m_left; }

  std::optional<net::const_buffer> pieceOf(const std::string& text) const {
    return net::const_buffer(text.data() + offset(), m_left);
  }
  std::optional<net::const_buffer> pieceOf(const HttpReply::MemoryPart& part) const {
    return net::const_buffer(part.content->bytes.data() + part.first + offset(), m_left);
  }
  std::optional<net::const_buffer> pieceOf(const HttpReply::FilePart& part) {
    std::optional<std::string> piece = part.file->read(part.first + offset(), std::min(m_left, kFilePieceBytes));
    if (!piece || piece->empty()) return std::nullopt;
    m_file_piece = std::move(*piece);
    return net::buffer(m_file_piece);
  }

  std::string m_head;
  HttpReply::Body m_body;
  std::size_t m_left;  // body bytes not yet taken into a piece
  std::size_t m_head_written = 0;
  net::const_buffer m_piece;  // the body's piece being written
  std::size_t m_piece_written = 0;
  std::string m_file_piece;  // a file's piece, read for m_piece
};

class Session;

// The listening socket, the io_context's threads, the open connections.
struct Listener {
  RequestHandler handler;
  std::string bind;
  int port = 0;
  int threads = 1;
  std::chrono::seconds read_timeout;
  std::chrono::seconds idle_timeout;
  std::uint32_t max_header_bytes = 0;
  int max_connections = 0;
  std::atomic<bool> stopping{false};

  // Open connections, for the limit and for stop(). Before the contexts:
  // connections still queued in a context unregister when it is destroyed.
  std::atomic<int> live{0};
  std::mutex sessions_mutex;
  std::unordered_map<Session*, std::weak_ptr<Session>> sessions;

  // One io_context per thread, each serving its share of the connections: no
  // lock shared by every request, no strand needed (a connection's handlers
  // run on its context's one thread).
  std::vector<std::unique_ptr<net::io_context>> contexts;
  std::size_t next_context = 0;
  tcp::acceptor acceptor;  // on contexts[0]
  net::steady_timer accept_retry;
  int failed_accepts = 0;  // in a row; one accept is pending at a time, so one thread at a time counts
  std::vector<net::executor_work_guard<net::io_context::executor_type>> work;

  Listener(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
           LayerSet::LookForNew look_for_new);
  void accept();
  void refuse(Socket& socket);
};

// One connection: reads request heads (never a body), answers them in order,
// keeps the connection while the client wants it and the timeouts allow.
// Everything it does runs on its io_context's thread; answers made on bake
// workers are dispatched there.
class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(Socket socket, Listener& server) : m_stream(std::move(socket)), m_server(server) {
    ++m_server.live;
    beast::error_code ec;
    m_stream.socket().set_option(tcp::no_delay(true), ec);
    const tcp::endpoint local = m_stream.socket().local_endpoint(ec);
    if (!ec) m_local_address = hostPort(local.address().to_string(), local.port());
  }

  ~Session() {
    {
      std::lock_guard<std::mutex> lock(m_server.sessions_mutex);
      m_server.sessions.erase(this);
    }
    --m_server.live;
  }

  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  void start() {
    {
      std::lock_guard<std::mutex> lock(m_server.sessions_mutex);
      m_server.sessions.emplace(this, weak_from_this());
    }
    net::dispatch(m_stream.get_executor(), [self = shared_from_this()] {
      // A connection's first request head must come within the read timeout.
      self->readRequestLine();
    });
  }

  net::any_io_executor executor() { return m_stream.get_executor(); }

  // From stop(), on the connection's thread: a connection waiting for a request closes now,
  // one with a request under way after its answer.
  void stopWhenIdle() {
    m_closing = true;
    if (!m_busy) m_stream.close();
  }

 private:
  // Reads until the buffer holds a request line, within the read timeout
  // (`started`: set already, for a line still coming in); drops the empty
  // lines before it (RFC 9112 2.2) and reads a later HTTP/1.x as HTTP/1.1,
  // which the parser would refuse; then the head.
  void readRequestLine(bool started = false) {
    if (m_closing || m_server.stopping) return m_stream.close();
    if (!started) m_stream.expires_after(m_server.read_timeout);
    m_buffer.consume(emptyLinesAtStart(bufferText()));
    const std::string_view text = bufferText();
    // Known from the line's start: a HEAD refused before its head is parsed is answered without a body too.
    m_head = text.substr(0, 5) == "HEAD ";
    const std::size_t end = text.find('\n');
    // The line alone past the head's limit: its target is what is too long (RFC 9112 3).
    if (std::min(end, text.size()) >= m_server.max_header_bytes) {
      return answerAndClose(m_server.handler.refusal(414, "request target too long"));
    }
    if (end == std::string_view::npos) {
      return m_stream.async_read_some(m_buffer.prepare(4096),
                                      [self = shared_from_this()](beast::error_code ec, std::size_t got) {
                                        if (ec) return self->m_stream.close();
                                        self->m_buffer.commit(got);
                                        self->readRequestLine(true);
                                      });
    }
    const std::string_view line = text.substr(0, end > 0 && text[end - 1] == '\r' ? end - 1 : end);
    switch (requestLineVersion(line)) {
      case LineVersion::kAsItIs: break;
      case LineVersion::kLaterMinor:
        static_cast<char*>(m_buffer.data().data())[line.size() - 1] = '1';
        break;
      case LineVersion::kOtherMajor:
        return answerAndClose(m_server.handler.refusal(505, "HTTP version not supported: use HTTP/1.1"));
    }
    readHead();
  }

  void readHead() {
    m_parser.emplace();
    // Beast holds the line and the fields to this each: the whole head's
    // size is checked once it is read (onHead).
    m_parser->header_limit(m_server.max_header_bytes);
    // No body is ever read, so none is too large to be announced: the answer (405, 501 or 413) comes first.
    m_parser->body_limit(std::numeric_limits<std::uint64_t>::max());
    http::async_read_header(
        m_stream, m_buffer, *m_parser,
        [self = shared_from_this()](beast::error_code ec, std::size_t head_bytes) { self->onHead(ec, head_bytes); });
  }

  std::string_view bufferText() const {
    const auto read = m_buffer.cdata();
    return {static_cast<const char*>(read.data()), read.size()};
  }

  // Between requests on a kept connection: the idle timeout until the next
  // request begins, then the read timeout for its head.
  void awaitNext() {
    if (m_closing || m_server.stopping) return m_stream.close();
    if (m_buffer.size() > 0) return readRequestLine();  // pipelined: it has begun
    m_stream.expires_after(m_server.idle_timeout);
    m_stream.async_read_some(m_buffer.prepare(4096),
                             [self = shared_from_this()](beast::error_code ec, std::size_t got) {
                               if (ec) return self->m_stream.close();
                               self->m_buffer.commit(got);
                               self->readRequestLine();
                             });
  }

  void onHead(beast::error_code ec, std::size_t head_bytes) {
    if (ec == http::error::header_limit || (!ec && head_bytes > m_server.max_header_bytes)) {
      return answerAndClose(m_server.handler.refusal(431, "request header fields too large"));
    }
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == net::error::operation_aborted ||
        ec == net::error::eof || ec == net::error::connection_reset) {
      return m_stream.close();  // gone, too slow, or stopped: nobody to answer
    }
    if (ec) return answerAndClose(m_server.handler.refusal(400, "bad request: " + ec.message()));

    const auto& request = m_parser->get();
    const std::string problem = framingProblem(request.version(), fieldLines(request, http::field::host),
                                               request.count(http::field::transfer_encoding) > 0, m_parser->chunked());
    if (!problem.empty()) {
      return answerAndClose(m_server.handler.refusal(400, "bad request: " + problem));
    }
    HttpRequest in;
    in.method = std::string(request.method_string());
    in.path = requestPath(std::string(request.target()));
    in.local_address = m_local_address;
    in.if_match = listField(request, http::field::if_match);
    in.if_none_match = listField(request, http::field::if_none_match);
    // Two Range lines are two ranges, answered whole like a list of them.
    in.range = listField(request, http::field::range);
    in.if_range = std::string(request[http::field::if_range]);
    in.cors_request_headers = listField(request, http::field::access_control_request_headers);
    const auto length = m_parser->content_length();
    in.has_body = m_parser->chunked() || (length && *length > 0);
    m_head = request.method() == http::verb::head;
    m_version = request.version();
    // A body is never read: after answering, its connection is closed.
    m_keep_alive =
        clientKeepsConnection(request.version(), fieldLines(request, http::field::connection)) && !in.has_body;
    m_unread_body = in.has_body;
    m_busy = true;
    m_stream.expires_never();  // waiting for a bake is not the client's delay
    try {
      m_server.handler.handle(in, [self = shared_from_this()](HttpReply reply) {
        net::dispatch(self->m_stream.get_executor(),
                      [self, reply = std::move(reply)]() mutable { self->write(std::move(reply)); });
      });
    } catch (const std::exception& e) {
      // Nothing was sent yet (the handler answers last): a 500 instead of a lost thread.
      log::error(in.method + " " + in.path + ": " + oneLine(e.what()));
      answerAndClose(m_server.handler.refusal(500, "internal error"));
    }
  }

  // The answer of a HEAD (m_head) has no body.
  void answerAndClose(HttpReply reply) {
    m_keep_alive = false;
    m_unread_body = true;  // whatever is left of the request stays unread
    m_version = 11;
    m_busy = true;
    write(std::move(reply));
  }

  void write(HttpReply reply) {
    const bool keep = m_keep_alive && !m_closing && !m_server.stopping;
    std::string head = responseHead(m_version, reply, bodyLength(reply.body), keep);
    sendSome(std::make_shared<Outgoing>(std::move(head), std::move(reply.body), !m_head), keep);
  }

  // Writes the answer as the socket takes it, each write within the read
  // timeout: a client that stops reading is cut off, a long download is not.
  // The head goes with the body's first piece.
  void sendSome(std::shared_ptr<Outgoing> out, bool keep) {
    const std::optional<std::array<net::const_buffer, 2>> buffers = out->unwritten();
    if (!buffers) {
      // A file that gives fewer bytes than it had when opened (changed while
      // read, as a copy in progress does): answered 503 if nothing was sent
      // yet, as a whole read is, else cut short.
      if (!out->started()) {
        return answerAndClose(m_server.handler.refusal(503, "busy: the file changed while read"));
      }
      return onWritten(make_error_code(boost::system::errc::io_error), keep);
    }
    m_stream.expires_after(m_server.read_timeout);
    m_stream.async_write_some(*buffers,
                              [self = shared_from_this(), out, keep](beast::error_code ec, std::size_t bytes) {
                                if (ec) return self->onWritten(ec, keep);
                                out->wrote(bytes);
                                if (out->done()) return self->onWritten(ec, keep);
                                self->sendSome(out, keep);
                              });
  }

  void onWritten(beast::error_code ec, bool keep) {
    m_busy = false;
    if (ec) return m_stream.close();
    if (m_unread_body || !keep) return linger();
    awaitNext();
  }

  // Answered, and not keeping the connection (a body left unread, or more
  // requests maybe pipelined behind a Connection: close): stop sending, drop
  // what still comes for a moment, close.
  void linger() {
    beast::error_code ignored;
    m_stream.socket().shutdown(tcp::socket::shutdown_send, ignored);
    m_buffer.clear();
    m_stream.expires_after(kLingerTime);
    drain();
  }

  void drain() {
    m_stream.async_read_some(m_buffer.prepare(16384), [self = shared_from_this()](beast::error_code ec, std::size_t got) {
      self->m_drained += got;
      if (ec || self->m_drained > kLingerBytes) return self->m_stream.close();
      self->drain();
    });
  }

  Stream m_stream;
  beast::flat_buffer m_buffer;
  std::optional<http::request_parser<http::empty_body>> m_parser;
  Listener& m_server;
  std::string m_local_address;
  unsigned m_version = 11;
  bool m_head = false;
  bool m_keep_alive = false;
  bool m_unread_body = false;
  bool m_busy = false;     // a request is being answered
  bool m_closing = false;  // stop(): close after the answer under way
  std::size_t m_drained = 0;
};

Listener::Listener(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
                   LayerSet::LookForNew look_for_new)
    : handler(config, std::move(layers), std::move(look_for_new)),
      bind(config.bind),
      threads(config.threads > 0 ? config.threads : usableCores().count),
      read_timeout(config.read_timeout_s),
      idle_timeout(config.idle_timeout_s),
      max_header_bytes(std::uint32_t(config.max_header_bytes)),
      max_connections(config.max_connections),
      contexts(makeContexts(threads)),
      acceptor(*contexts[0]),
      accept_retry(*contexts[0]) {
  raiseFileLimit(max_connections);
  const std::string where = hostPort(config.bind, config.port);
  beast::error_code ec;
  tcp::resolver resolver(*contexts[0]);
  const auto endpoints = resolver.resolve(config.bind, std::to_string(config.port),
                                          tcp::resolver::passive | tcp::resolver::numeric_service, ec);
  if (ec || endpoints.empty()) {
    throw InputError("http: cannot listen on " + where + ": " + (ec ? ec.message() : "no such address"));
  }
  const tcp::endpoint endpoint = endpoints.begin()->endpoint();
  acceptor.open(endpoint.protocol(), ec);
  // SO_REUSEADDR for a quick restart, and not SO_REUSEPORT, with which a
  // second server would bind a port in use and take half its connections.
  if (!ec) acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) throw InputError("http: cannot listen on " + where + ": " + ec.message());
  port = acceptor.local_endpoint().port();
}

void Listener::accept() {
  net::io_context& context = *contexts[next_context++ % contexts.size()];
  acceptor.async_accept(context, [this](beast::error_code ec, Socket socket) {
    if (ec == net::error::operation_aborted || !acceptor.is_open()) return;
    if (ec) {
      // Out of file descriptors, most likely: the connections ahead must
      // close first. Said once, not at every retry.
      if (failed_accepts++ == 0) log::warning("http: accept failed: " + ec.message() + "; retrying");
      accept_retry.expires_after(kAcceptRetry);
      accept_retry.async_wait([this](beast::error_code) {
        if (acceptor.is_open()) accept();
      });
      return;
    }
    if (failed_accepts > 0) {
      log::info("http: accepting again after " + std::to_string(failed_accepts) + " failed accepts");
      failed_accepts = 0;
    }
    if (live >= max_connections) {
      refuse(socket);
    } else {
      std::make_shared<Session>(std::move(socket), *this)->start();
    }
    accept();
  });
}

// Past the connection limit: a 503 written once, without waiting, and closed.
// Nothing of the request is read and nothing is queued.
void Listener::refuse(Socket& socket) {
  const HttpReply reply = handler.refusal(503, "busy: too many connections");
  const std::string text = responseHead(11, reply, bodyLength(reply.body), false) + std::get<std::string>(reply.body);
  beast::error_code ec;
  socket.non_blocking(true, ec);
  socket.write_some(net::buffer(text), ec);
  socket.shutdown(tcp::socket::shutdown_both, ec);
  socket.close(ec);
}

}  // namespace

struct Server::Impl : Listener {
  using Listener::Listener;
};

Server::Server(const config::ServeConfig& config, std::vector<std::unique_ptr<LayerSource>> layers,
               LayerSet::LookForNew look_for_new)
    : m_impl(std::make_unique<Impl>(config, std::move(layers), std::move(look_for_new))) {}

Server::~Server() { m_impl->handler.stopLayers(); }

int Server::port() const { return m_impl->port; }

std::string Server::url() const { return "http://" + hostPort(m_impl->bind, m_impl->port) + "/"; }

void Server::run() {
  if (m_impl->stopping) return;
  // Keeps the threads up until stop() has every bake answered (see stop()).
  for (const auto& context : m_impl->contexts) m_impl->work.push_back(net::make_work_guard(*context));
  // Every context needs its thread: where the system refuses one, those
  // started end (they have no work yet) and the server does not start.
  std::string refused;
  std::vector<std::thread> helpers = startThreads(
      int(m_impl->contexts.size()) - 1, [this](int k) { runContext(*m_impl->contexts[std::size_t(k) + 1]); },
      refused);
  // However run() ends, the helpers end first (a thread left running would
  // end the process): released by stop() once served, else here, where
  // nothing runs the first context that stop() would release them on.
  struct JoinHelpers {
    Impl& impl;
    std::vector<std::thread>& helpers;
    bool served = false;
    ~JoinHelpers() {
      if (!served) {
        for (auto& guard : impl.work) guard.reset();
      }
      for (std::thread& helper : helpers) helper.join();
    }
  } join{*m_impl, helpers};
  if (!refused.empty()) {
    throw InputError("http: cannot start " + std::to_string(m_impl->contexts.size()) + " threads: " + refused +
                     "; set fewer with http.threads");
  }
  m_impl->accept();
  runContext(*m_impl->contexts[0]);
  join.served = true;
}

void Server::stop() {
  Impl& impl = *m_impl;
  impl.stopping = true;
  net::post(*impl.contexts[0], [&impl] {
    beast::error_code ignored;
    impl.acceptor.close(ignored);
    impl.accept_retry.cancel();
    // Taken out under the lock, told outside it: the last reference to a
    // session may be dropped here, and its destructor takes the lock too.
    std::vector<std::shared_ptr<Session>> open;
    {
      std::lock_guard<std::mutex> lock(impl.sessions_mutex);
      for (const auto& [pointer, weak] : impl.sessions) {
        if (std::shared_ptr<Session> session = weak.lock()) open.push_back(std::move(session));
      }
    }
    for (const std::shared_ptr<Session>& session : open) {
      net::post(session->executor(), [session] { session->stopWhenIdle(); });
    }
  });
  // Queued bakes are answered 503 at once, running ones when they finish;
  // their answers are on the io_context's queue when this returns.
  impl.handler.stopLayers();
  for (std::size_t i = 0; i < impl.contexts.size(); ++i) {
    net::post(*impl.contexts[i], [&impl, i] {
      if (i < impl.work.size()) impl.work[i].reset();
    });
  }
}

}  // namespace terrabake::server
