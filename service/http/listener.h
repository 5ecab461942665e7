// Accepts TCP connections and starts an HttpSession on each, every connection on a strand
// of its own (Beast's advanced server). At HttpLimits::max_connections a new connection
// takes the place of the one that has waited longest for a request (connection_table.h);
// when every connection is busy answering, it gets 503 too_many_connections. stop()
// closes the acceptor: no new connection is accepted, sessions already open finish their
// requests.
//
// Thread-safe: run() and stop() post to the acceptor's strand.
#pragma once

#include <memory>
#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/error.hpp>

#include "base/result.h"
#include "service/http/http_limits.h"
#include "service/http/http_session.h"

namespace camlab::service {

class Router;

// Parses "HOST:PORT" or "[V6]:PORT" (port 0: an ephemeral port).
Result<boost::asio::ip::tcp::endpoint> parse_listen_address(const std::string& text);

class Listener : public std::enable_shared_from_this<Listener> {
 public:
  // Binds and listens; errors name the address (e.g. "address already in use").
  static Result<std::shared_ptr<Listener>> create(boost::asio::io_context& ioc,
                                                  const boost::asio::ip::tcp::endpoint& endpoint,
                                                  const Router& router, const HttpLimits& limits);
  void run();
  void stop();
  boost::asio::ip::tcp::endpoint local_endpoint() const;

 private:
  Listener(boost::asio::io_context& ioc, const Router& router, const HttpLimits& limits);
  void do_accept();
  void on_accept(boost::beast::error_code ec, boost::asio::ip::tcp::socket socket);
  // Answers 503 too_many_connections and closes (no session).
  static void refuse(boost::asio::ip::tcp::socket socket);

  boost::asio::io_context& ioc_;
  boost::asio::ip::tcp::acceptor acceptor_;
  const Router& router_;
  const HttpLimits& limits_;
  std::shared_ptr<ConnectionCount> connections_;
};

}  // namespace camlab::service
