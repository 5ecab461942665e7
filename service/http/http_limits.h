// Bounds on everything an HTTP client sends (docs/architecture.md: everything from outside is
// bounded). Plain values.
#pragma once

#include <chrono>
#include <cstddef>

namespace camlab::service {

struct HttpLimits {
  size_t max_body_bytes = 1 << 20;         // JSON bodies are small; 413 above
  size_t max_header_bytes = 8192;          // request line + headers; 431 above
  std::chrono::seconds read_timeout{15};   // a request must arrive within this (slowloris)
  std::chrono::seconds write_timeout{30};  // a response must drain within this
  // Further connections make room by evicting (service/http/connection_table.h) or get 503;
  // one peer address may hold at most half of them.
  int max_connections = 256;
};

}  // namespace camlab::service
