// What every harness asserts beyond "no crash, no sanitizer report": a parser's outputs
// are finite and its errors say something. A failed check aborts, which libFuzzer reports
// as a crash with the input that caused it.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

namespace camlab::fuzz {

inline void check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz check failed: %s\n", what);
  std::abort();
}

inline void check_finite(double value, const char* what) { check(std::isfinite(value), what); }

// An error must say what is wrong: its code is typed (base/error_code.h), its message
// must not be empty.
template <class E>
void check_error(const E& error) {
  check(!error.message.empty(), "error without a message");
}

// Splits a fuzz input into up to `count` parts at a separator line, so one input can
// stand for several files (a capture folder's manifest, journal and sidecar).
inline std::vector<std::string> split_parts(std::string_view text, size_t count) {
  constexpr std::string_view kSeparator = "\n--8<--\n";
  std::vector<std::string> parts;
  while (parts.size() + 1 < count) {
    const size_t at = text.find(kSeparator);
    if (at == std::string_view::npos) break;
    parts.emplace_back(text.substr(0, at));
    text.remove_prefix(at + kSeparator.size());
  }
  parts.emplace_back(text);
  parts.resize(count);
  return parts;
}

}  // namespace camlab::fuzz
