// A TCP proxy on 127.0.0.1 for tests that cut a host off from its database: it forwards
// bytes both ways until cut(), then holds every connection open without passing anything
// on, and accepts new ones without connecting them anywhere (a pulled cable, not a
// refused connection: the client hears nothing). restore() closes what it held and
// forwards again.
//
// Thread-safe: one thread of its own; cut() and restore() from any thread.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

namespace camlab::testing {

class TcpProxy {
 public:
  // Forwards 127.0.0.1:port() to 127.0.0.1:target_port.
  explicit TcpProxy(int target_port) : target_port_(target_port) {
    listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int yes = 1;
    ::setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof addr;
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
        ::listen(listener_, 64) == 0 &&
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &size) == 0)
      port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { run(); });
  }
  ~TcpProxy() {
    stop_ = true;
    thread_.join();
    close_all();
    ::close(listener_);
  }
  TcpProxy(const TcpProxy&) = delete;
  TcpProxy& operator=(const TcpProxy&) = delete;

  int port() const { return port_; }
  void cut() { cut_ = true; }
  void restore() {
    std::lock_guard lock(mutex_);
    close_all_locked();
    cut_ = false;
  }

 private:
  struct Pair {
    int client = -1, server = -1;  // server -1: held while cut
  };

  int connect_target() const {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(target_port_));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd);
      return -1;
    }
    return fd;
  }

  void close_all_locked() {
    for (Pair& p : pairs_) {
      if (p.client >= 0) ::close(p.client);
      if (p.server >= 0) ::close(p.server);
    }
    pairs_.clear();
  }
  void close_all() {
    std::lock_guard lock(mutex_);
    close_all_locked();
  }

  // Copies what `from` has to `to`; false when either end is done.
  static bool pump(int from, int to) {
    char buffer[65536];
    const ssize_t n = ::recv(from, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n <= 0) return false;
    for (ssize_t sent = 0; sent < n;) {
      const ssize_t m = ::send(to, buffer + sent, static_cast<size_t>(n - sent), MSG_NOSIGNAL);
      if (m <= 0) return false;
      sent += m;
    }
    return true;
  }

  void run() {
    while (!stop_) {
      std::vector<pollfd> fds{{listener_, POLLIN, 0}};
      {
        std::lock_guard lock(mutex_);
        if (!cut_)
          for (const Pair& p : pairs_) {
            fds.push_back({p.client, POLLIN, 0});
            fds.push_back({p.server, POLLIN, 0});
          }
      }
      if (::poll(fds.data(), fds.size(), 50) <= 0) continue;
      std::lock_guard lock(mutex_);
      if (fds[0].revents & POLLIN) {
        const int client = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
        if (client >= 0) pairs_.push_back({client, cut_ ? -1 : connect_target()});
      }
      if (cut_) continue;
      for (size_t i = 1; i + 1 < fds.size(); i += 2) {
        const int client = fds[i].fd, server = fds[i + 1].fd;
        bool alive = server >= 0;
        if (alive && (fds[i].revents & (POLLIN | POLLHUP | POLLERR))) alive = pump(client, server);
        if (alive && (fds[i + 1].revents & (POLLIN | POLLHUP | POLLERR)))
          alive = pump(server, client);
        if (!alive)
          for (Pair& p : pairs_)
            if (p.client == client) {
              ::close(p.client);
              if (p.server >= 0) ::close(p.server);
              p.client = p.server = -1;
            }
      }
      std::erase_if(pairs_, [](const Pair& p) { return p.client < 0; });
    }
  }

  const int target_port_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> cut_{false}, stop_{false};
  std::mutex mutex_;
  std::vector<Pair> pairs_;
  std::thread thread_;
};

}  // namespace camlab::testing
