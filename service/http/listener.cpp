#include "service/http/listener.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <string>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/bind_handler.hpp>

#include "base/log.h"

namespace camlab::service {

namespace net = boost::asio;
namespace beast = boost::beast;
using tcp = net::ip::tcp;

Result<tcp::endpoint> parse_listen_address(const std::string& text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon + 1 >= text.size())
    return make_error("invalid_request",
                      "--listen must be HOST:PORT, e.g. 127.0.0.1:8080, not '" + text + "'");
  std::string host = text.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  const std::string port_text = text.substr(colon + 1);
  if (port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string::npos)
    return make_error("invalid_request",
                      "--listen port must be a number in [0, 65535], not '" + port_text + "'");
  const int port = std::stoi(port_text);
  if (port > 65535) return make_error("invalid_request", "--listen port must be in [0, 65535]");
  if (host == "localhost") host = "127.0.0.1";
  beast::error_code ec;
  const net::ip::address address = net::ip::make_address(host, ec);
  if (ec)
    return make_error("invalid_request", "--listen host must be an IP address, not '" + host + "'");
  return tcp::endpoint(address, static_cast<unsigned short>(port));
}

Listener::Listener(net::io_context& ioc, const Router& router, const HttpLimits& limits)
    : ioc_(ioc),
      acceptor_(net::make_strand(ioc)),
      router_(router),
      limits_(limits),
      connections_(std::make_shared<ConnectionCount>()) {}

Result<std::shared_ptr<Listener>> Listener::create(net::io_context& ioc,
                                                   const tcp::endpoint& endpoint,
                                                   const Router& router, const HttpLimits& limits) {
  std::shared_ptr<Listener> listener(new Listener(ioc, router, limits));
  beast::error_code ec;
  const std::string where = endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
  auto fail = [&](const char* what) {
    return make_error("io_error",
                      std::string("cannot ") + what + " " + where + ": " + ec.message());
  };
  listener->acceptor_.open(endpoint.protocol(), ec);
  if (ec) return fail("open a socket for");
  listener->acceptor_.set_option(net::socket_base::reuse_address(true), ec);
  if (ec) return fail("set SO_REUSEADDR on");
  listener->acceptor_.bind(endpoint, ec);
  if (ec) return fail("bind");
  listener->acceptor_.listen(net::socket_base::max_listen_connections, ec);
  if (ec) return fail("listen on");
  return listener;
}

tcp::endpoint Listener::local_endpoint() const {
  beast::error_code ec;
  return acceptor_.local_endpoint(ec);
}

void Listener::run() {
  net::dispatch(acceptor_.get_executor(),
                beast::bind_front_handler(&Listener::do_accept, shared_from_this()));
}

void Listener::stop() {
  net::dispatch(acceptor_.get_executor(), [self = shared_from_this()] {
    beast::error_code ec;
    self->acceptor_.close(ec);
  });
}

void Listener::do_accept() {
  // Each connection gets a strand of its own: its handlers never run concurrently.
  acceptor_.async_accept(net::make_strand(ioc_),
                         beast::bind_front_handler(&Listener::on_accept, shared_from_this()));
}

void Listener::on_accept(beast::error_code ec, tcp::socket socket) {
  if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;  // stopped
  if (ec) {
    log_warning(log::Category::kHttp, "accept: %s", ec.message().c_str());
  } else {
    beast::error_code peer_ec;
    const auto peer = socket.remote_endpoint(peer_ec);
    const std::string address = peer_ec ? "" : peer.address().to_string();
    // One address may hold half the connections: another client always finds room.
    const int per_address = std::max(1, limits_.max_connections / 2);
    const bool address_full = connections_->table.count_from(address) >= per_address;
    bool admit = connections_->open.load() < limits_.max_connections && !address_full;
    if (!admit) {
      // Full: make room by closing the connection that has waited longest for a request,
      // or failing that the one blocked longest writing to a client that reads nothing
      // (at least a second either way: a client that just connected gets its chance).
      // An address at its own limit gives way to itself.
      if (auto longest = connections_->table.take_evictable(std::chrono::seconds(1),
                                                            address_full ? &address : nullptr)) {
        longest->evict();
        admit = true;  // over the limit by one until it closes, a moment from now
      }
    }
    if (admit) {
      ++connections_->open;
      std::make_shared<HttpSession>(std::move(socket), router_, limits_, connections_)->run();
    } else {
      refuse(std::move(socket));
    }
  }
  do_accept();
}

void Listener::refuse(tcp::socket socket) {
  // Every connection is busy answering a request: an HTTP answer, not a reset. Written
  // without waiting (a 503 fits any socket buffer); what the client sent is read off
  // before the close, which would otherwise send a reset that can discard the answer.
  static const std::string kAnswer = [] {
    const std::string body =
        "{\"error\":{\"code\":\"too_many_connections\",\"message\":\"every connection "
        "camlabd accepts is busy answering a request; retry in a second\"}}";
    return "HTTP/1.1 503 Service Unavailable\r\nServer: camlabd\r\nContent-Type: "
           "application/json\r\nRetry-After: 1\r\nConnection: close\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\n\r\n" + body;
  }();
  beast::error_code ec;
  socket.non_blocking(true, ec);
  socket.write_some(net::buffer(kAnswer), ec);
  socket.shutdown(tcp::socket::shutdown_send, ec);
  std::array<char, 4096> unread{};
  for (int i = 0; i < 16 && !ec; ++i) socket.read_some(net::buffer(unread), ec);
  socket.close(ec);
}

}  // namespace camlab::service
