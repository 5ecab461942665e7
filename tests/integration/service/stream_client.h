// A client of camlabd's streamed answers (the live view's multipart JPEG stream, the
// server-sent events): one loopback connection, the head read once, then parts or events
// read one at a time, each under a deadline, so a test or a benchmark never hangs on a
// stream that stopped.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <optional>
#include <string>

namespace camlab::testing {

class StreamClient {
 public:
  using Clock = std::chrono::steady_clock;

  ~StreamClient() { close(); }

  // Connects, sends GET `path` with the token, reads the status line and headers.
  bool open(int port, const std::string& path, const std::string& token,
            std::chrono::milliseconds timeout = std::chrono::milliseconds(10000)) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) return false;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return false;
    std::string request = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n";
    if (!token.empty()) request += "Authorization: Bearer " + token + "\r\n";
    request += "\r\n";
    if (::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) !=
        static_cast<ssize_t>(request.size()))
      return false;
    const auto deadline = Clock::now() + timeout;
    size_t end;
    while ((end = buffer_.find("\r\n\r\n")) == std::string::npos)
      if (!fill(deadline)) return false;
    const std::string head = buffer_.substr(0, end);
    buffer_.erase(0, end + 4);
    if (head.size() >= 12) status_ = std::atoi(head.substr(9, 3).c_str());
    headers_ = parse_headers(
        head.substr(head.find("\r\n") == std::string::npos ? head.size() : head.find("\r\n") + 2));
    return true;
  }

  int status() const { return status_; }
  std::string header(const std::string& lower_case_name) const {
    auto it = headers_.find(lower_case_name);
    return it == headers_.end() ? "" : it->second;
  }
  // The body of a non-streamed answer (an error), read until the length says.
  std::string error_body(std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
    const size_t length = std::strtoul(header("content-length").c_str(), nullptr, 10);
    const auto deadline = Clock::now() + timeout;
    while (buffer_.size() < length && fill(deadline)) {
    }
    return buffer_.substr(0, length);
  }

  struct Part {
    std::map<std::string, std::string> headers;  // names lower-cased
    std::string body;
  };
  // The next part of a multipart stream; nullopt when the stream ended or the deadline
  // passed (ended() tells which).
  std::optional<Part> next_part(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    size_t end;
    while ((end = buffer_.find("\r\n\r\n")) == std::string::npos)
      if (!fill(deadline)) return std::nullopt;
    Part part;
    part.headers = parse_headers(buffer_.substr(0, end));
    const size_t length = std::strtoul(part.headers["content-length"].c_str(), nullptr, 10);
    while (buffer_.size() < end + 4 + length + 2)
      if (!fill(deadline)) return std::nullopt;
    part.body = buffer_.substr(end + 4, length);
    buffer_.erase(0, end + 4 + length + 2);
    return part;
  }

  // The next server-sent event block (lines up to a blank line), comments included.
  std::optional<std::string> next_event(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    size_t end;
    while ((end = buffer_.find("\n\n")) == std::string::npos)
      if (!fill(deadline)) return std::nullopt;
    std::string block = buffer_.substr(0, end);
    buffer_.erase(0, end + 2);
    return block;
  }

  bool ended() const { return ended_; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  static std::map<std::string, std::string> parse_headers(const std::string& text) {
    std::map<std::string, std::string> out;
    size_t start = 0;
    while (start < text.size()) {
      size_t end = text.find("\r\n", start);
      if (end == std::string::npos) end = text.size();
      const std::string line = text.substr(start, end - start);
      const size_t colon = line.find(':');
      if (colon != std::string::npos) {
        std::string name = line.substr(0, colon);
        for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        std::string value = line.substr(colon + 1);
        value.erase(0, value.find_first_not_of(' '));
        out[name] = value;
      }
      start = end + 2;
    }
    return out;
  }

  // Reads what has arrived (waiting until the deadline); false at the end or the deadline.
  bool fill(Clock::time_point deadline) {
    if (fd_ < 0 || ended_) return false;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left)) <= 0) return false;
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
    if (n <= 0) {
      ended_ = true;
      return false;
    }
    buffer_.append(chunk, static_cast<size_t>(n));
    return true;
  }

  int fd_ = -1;
  int status_ = 0;
  bool ended_ = false;
  std::map<std::string, std::string> headers_;
  std::string buffer_;
};

}  // namespace camlab::testing
