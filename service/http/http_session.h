// One HTTP/1.1 connection, in the shape of Beast's advanced server: the session owns
// itself through shared_from_this while an operation is pending, and every step runs on
// the connection's strand (the socket's executor), so the session needs no locks.
// Requests are read with a parser bounded in header and body size under a timeout; each
// is converted to an ApiRequest and dispatched through the Router; the reply (from any
// thread: a camera worker answers control changes) is posted back onto the strand and
// written; keep-alive connections then read the next request.
//
// A streamed answer (ApiResponse::stream: the live view, server-sent events) is written as
// its head, then one piece at a time as the stream delivers them, each write under the
// write timeout; the connection closes when the stream ends or a write fails.
//
// A request over a limit gets its 4xx (413, 431, 400) and the connection is closed after
// draining what the client is still sending, so that it reads the answer, not a reset.
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>

#include "service/api/api_types.h"
#include "service/http/connection_table.h"
#include "service/http/http_limits.h"

namespace camlab::service {

class Router;

// Open sessions, for HttpLimits::max_connections, and what each is doing (for eviction
// when full). Thread-safe.
struct ConnectionCount {
  std::atomic<int> open{0};
  ConnectionTable table;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(boost::asio::ip::tcp::socket&& socket, const Router& router, const HttpLimits& limits,
              std::shared_ptr<ConnectionCount> connections);
  ~HttpSession();

  // Starts reading on the session's strand.
  void run();
  // Closes the connection from any thread (on its strand): the server is full and this
  // one was waiting longest for a request, or blocked longest writing (connection_table.h).
  void evict();

 private:
  void do_read();
  void on_read(boost::beast::error_code ec, std::size_t bytes);
  // Called on the strand with the handler's answer.
  void send(ApiResponse response, bool close_after);
  void on_write(bool close_after, boost::beast::error_code ec, std::size_t bytes);
  // A streamed answer: the head, then each piece (see the header comment).
  void start_stream(ApiResponse response);
  void on_stream_head(boost::beast::error_code ec, std::size_t bytes);
  // Reads from a stream's client until it closes, then ends the stream.
  void watch_peer();
  void ask_stream();
  void on_stream_piece(std::optional<std::string> piece);
  void on_stream_written(boost::beast::error_code ec, std::size_t bytes);
  void end_stream();
  // BodyStream::close(), once (the client's leaving and a failed write may both ask).
  void close_body_stream();
  // Half-closes, then reads and drops what the client still sends (bounded in bytes
  // and time) before closing, so the client sees the error response.
  void drain_and_close();
  void on_drain(boost::beast::error_code ec, std::size_t bytes);
  void do_close();

  boost::beast::tcp_stream stream_;
  boost::beast::flat_buffer buffer_;
  const Router& router_;
  const HttpLimits& limits_;
  std::shared_ptr<ConnectionCount> connections_;
  uint64_t table_id_ = 0;  // in connections_->table, from run()
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> parser_;
  std::optional<boost::beast::http::response<boost::beast::http::string_body>> response_;
  std::optional<boost::beast::http::response<boost::beast::http::empty_body>> stream_head_;
  std::shared_ptr<BodyStream> body_stream_;
  bool body_stream_closed_ = false;
  std::string stream_piece_;  // being written
  // Pipelined requests answered in a row (see on_write).
  static constexpr int kMaxPipelinedRequests = 32;
  int pipelined_requests_ = 0;
  unsigned http_version_ = 11;
  bool keep_alive_ = false;
  bool head_request_ = false;
  std::array<char, 16384> drain_buffer_{};
  std::size_t drained_bytes_ = 0;
};

}  // namespace camlab::service
