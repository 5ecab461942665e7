#include "service/http/http_session.h"

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/bind_handler.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/write.hpp>

#include "service/api/router.h"

namespace camlab::service {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;

namespace {

// What a client may still be sending after an over-limit request: drained up to this.
constexpr std::size_t kMaxDrainBytes = 64u << 20;
constexpr std::chrono::seconds kDrainTimeout{3};

std::string header(const http::request<http::string_body>& request, http::field field) {
  auto it = request.find(field);
  return it == request.end() ? std::string() : std::string(it->value());
}

}  // namespace

HttpSession::HttpSession(net::ip::tcp::socket&& socket, const Router& router,
                         const HttpLimits& limits, std::shared_ptr<ConnectionCount> connections)
    : stream_(std::move(socket)),
      router_(router),
      limits_(limits),
      connections_(std::move(connections)) {}

HttpSession::~HttpSession() {
  if (table_id_ != 0) connections_->table.remove(table_id_);
  --connections_->open;
}

void HttpSession::run() {
  beast::error_code ec;
  const auto peer = stream_.socket().remote_endpoint(ec);
  table_id_ = connections_->table.add(weak_from_this(), ec ? "" : peer.address().to_string());
  // The socket's executor is this connection's strand (the acceptor made it so).
  net::dispatch(stream_.get_executor(),
                beast::bind_front_handler(&HttpSession::do_read, shared_from_this()));
}

void HttpSession::evict() {
  net::post(stream_.get_executor(), [self = shared_from_this()] { self->do_close(); });
}

void HttpSession::do_read() {
  // A new parser per request: limits apply to each request, not to the connection.
  parser_.emplace();
  parser_->header_limit(static_cast<std::uint32_t>(limits_.max_header_bytes));
  parser_->body_limit(limits_.max_body_bytes);
  stream_.expires_after(limits_.read_timeout);
  connections_->table.waiting(table_id_);
  http::async_read(stream_, buffer_, *parser_,
                   beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
}

void HttpSession::on_read(beast::error_code ec, std::size_t) {
  if (ec == http::error::end_of_stream || ec == beast::error::timeout ||
      ec == net::error::operation_aborted || ec == net::error::connection_reset ||
      ec == net::error::eof)
    return do_close();
  if (ec == http::error::body_limit)
    return send(
        error_response("payload_too_large", "the request body is larger than " +
                                                std::to_string(limits_.max_body_bytes) + " bytes"),
        true);
  if (ec == http::error::header_limit)
    return send(error_response("headers_too_large", "the request headers are larger than " +
                                                        std::to_string(limits_.max_header_bytes) +
                                                        " bytes"),
                true);
  if (ec) {
    if (std::string_view(ec.category().name()) == "beast.http")
      return send(error_response("invalid_request", "malformed HTTP request: " + ec.message()),
                  true);
    return do_close();
  }

  connections_->table.answering(table_id_);
  http::request<http::string_body> request = parser_->release();
  http_version_ = request.version();
  keep_alive_ = request.keep_alive();
  head_request_ = request.method() == http::verb::head;

  ApiRequest api;
  api.method = std::string(request.method_string());
  const std::string target(request.target());
  // Origin form only (RFC 9112 3.2.1): "v1/jobs" or an absolute URI would otherwise be
  // routed as if it were the path it resembles.
  if (target.empty() || target[0] != '/')
    return send(error_response("invalid_request",
                               "the request target must be a path starting with '/', e.g. "
                               "/v1/cameras"),
                !keep_alive_);
  const size_t question = target.find('?');
  api.path = target.substr(0, question);
  if (question != std::string::npos) api.query = target.substr(question + 1);
  api.body = std::move(request.body());
  api.authorization = header(request, http::field::authorization);
  api.content_type = header(request, http::field::content_type);
  beast::error_code endpoint_ec;
  const auto remote = stream_.socket().remote_endpoint(endpoint_ec);
  if (!endpoint_ec) api.remote = remote.address().to_string();

  // No timer runs while the handler works: it always replies (a camera task replies
  // when the camera answers), and the write below has its own timeout.
  stream_.expires_never();
  router_.dispatch(api, [self = shared_from_this()](ApiResponse response) {
    net::post(self->stream_.get_executor(), [self, response = std::move(response)]() mutable {
      self->send(std::move(response), !self->keep_alive_);
    });
  });
}

void HttpSession::send(ApiResponse api, bool close_after) {
  if (api.stream) return start_stream(std::move(api));
  response_.emplace(static_cast<http::status>(api.status), http_version_);
  response_->set(http::field::server, "camlabd");
  response_->set(http::field::content_type, api.content_type);
  response_->set(http::field::cache_control, "no-store");
  for (const auto& [name, value] : api.headers) response_->set(name, value);
  response_->keep_alive(!close_after);
  response_->body() = std::move(api.body);
  response_->prepare_payload();
  if (head_request_) response_->body().clear();  // Content-Length stays that of the GET
  // A client that sends requests and reads no answers is the writer's to evict when full.
  connections_->table.writing(table_id_);
  stream_.expires_after(limits_.write_timeout);
  http::async_write(
      stream_, *response_,
      beast::bind_front_handler(&HttpSession::on_write, shared_from_this(), close_after));
}

void HttpSession::on_write(bool close_after, beast::error_code ec, std::size_t) {
  response_.reset();
  if (ec) return do_close();
  if (close_after) {
    // An over-limit or malformed request leaves unread bytes behind: drain them.
    if (parser_ && !parser_->is_done()) return drain_and_close();
    return do_close();
  }
  // Requests that had all arrived before the one just answered was written (pipelined)
  // are answered up to kMaxPipelinedRequests in a row; then the connection closes, and
  // a client that reads its answers opens another.
  pipelined_requests_ = buffer_.size() > 0 ? pipelined_requests_ + 1 : 0;
  if (pipelined_requests_ >= kMaxPipelinedRequests) return do_close();
  do_read();
}

void HttpSession::start_stream(ApiResponse api) {
  body_stream_ = std::move(api.stream);
  stream_head_.emplace(static_cast<http::status>(api.status), http_version_);
  stream_head_->set(http::field::server, "camlabd");
  stream_head_->set(http::field::content_type, api.content_type);
  stream_head_->set(http::field::cache_control, "no-store");
  for (const auto& [name, value] : api.headers) stream_head_->set(name, value);
  // No length: the body ends when the connection does (RFC 9112 6.3), which every client
  // of a stream reads that way.
  stream_head_->keep_alive(false);
  connections_->table.writing(table_id_);
  stream_.expires_after(limits_.write_timeout);
  http::async_write(stream_, *stream_head_,
                    beast::bind_front_handler(&HttpSession::on_stream_head, shared_from_this()));
}

void HttpSession::on_stream_head(beast::error_code ec, std::size_t) {
  stream_head_.reset();
  if (ec || head_request_) return end_stream();
  watch_peer();
  ask_stream();
}

void HttpSession::watch_peer() {
  // A stream's client sends nothing more; a read completes when it closes (or resets), so
  // the stream's slot is freed then, not when the next heartbeat fails to be written (an
  // event stream kept its slot 14.6 s after its client left). What it might send is
  // dropped.
  stream_.socket().async_read_some(net::buffer(drain_buffer_),
                                   [self = shared_from_this()](beast::error_code ec, std::size_t) {
                                     if (!self->body_stream_) return;
                                     if (!ec) return self->watch_peer();
                                     // The client left: free what the stream holds now. The stream
                                     // object itself stays until its pending next() answers or is
                                     // dropped (it may be answering right now on another thread,
                                     // through an object that must still exist), so it is only
                                     // closed here; that answer then fails to be written and ends
                                     // the stream as any failed write does.
                                     self->close_body_stream();
                                     self->do_close();
                                   });
}

void HttpSession::ask_stream() {
  stream_.expires_never();  // waiting for the next piece is not the client's fault
  connections_->table.answering(table_id_);
  body_stream_->next([self = shared_from_this()](std::optional<std::string> piece) {
    net::post(self->stream_.get_executor(), [self, piece = std::move(piece)]() mutable {
      self->on_stream_piece(std::move(piece));
    });
  });
}

void HttpSession::on_stream_piece(std::optional<std::string> piece) {
  if (!body_stream_) return;
  if (!piece) return end_stream();
  stream_piece_ = std::move(*piece);
  connections_->table.writing(table_id_);
  stream_.expires_after(limits_.write_timeout);
  net::async_write(stream_, net::buffer(stream_piece_),
                   beast::bind_front_handler(&HttpSession::on_stream_written, shared_from_this()));
}

void HttpSession::on_stream_written(beast::error_code ec, std::size_t) {
  if (ec) return end_stream();
  ask_stream();
}

void HttpSession::close_body_stream() {
  if (body_stream_ && !body_stream_closed_) body_stream_->close();
  body_stream_closed_ = true;
}

void HttpSession::end_stream() {
  if (body_stream_) {
    close_body_stream();
    body_stream_.reset();
  }
  do_close();
}

void HttpSession::drain_and_close() {
  beast::error_code ec;
  stream_.socket().shutdown(net::ip::tcp::socket::shutdown_send, ec);
  drained_bytes_ = 0;
  stream_.expires_after(kDrainTimeout);
  stream_.async_read_some(net::buffer(drain_buffer_),
                          beast::bind_front_handler(&HttpSession::on_drain, shared_from_this()));
}

void HttpSession::on_drain(beast::error_code ec, std::size_t bytes) {
  drained_bytes_ += bytes;
  if (ec || drained_bytes_ > kMaxDrainBytes) return do_close();
  stream_.async_read_some(net::buffer(drain_buffer_),
                          beast::bind_front_handler(&HttpSession::on_drain, shared_from_this()));
}

void HttpSession::do_close() {
  beast::error_code ec;
  stream_.socket().shutdown(net::ip::tcp::socket::shutdown_both, ec);
  stream_.socket().close(ec);
}

}  // namespace camlab::service
