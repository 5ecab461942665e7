// Numbers and printf formats into std::string: the one place camlab formats numbers for
// messages, reports and plots.
//
//   format_significant(0.000123456, 3)   "0.000123"
//   format_significant(1.5e6, 3)         "1.5e+06"
//   format_printf("%.2f px", 1.234)      "1.23 px"
//
// Reentrant. Header-only, so that src/optics (which links nothing) can use it.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace camlab {

// printf into a std::string of any length.
inline std::string vformat_printf(const char* format, va_list args)
    __attribute__((format(printf, 1, 0)));
inline std::string vformat_printf(const char* format, va_list args) {
  char small[128];
  va_list again;
  va_copy(again, args);
  const int needed = std::vsnprintf(small, sizeof small, format, args);
  if (needed < 0) {
    va_end(again);
    return {};
  }
  if (static_cast<size_t>(needed) < sizeof small) {
    va_end(again);
    return std::string(small, static_cast<size_t>(needed));
  }
  std::string text(static_cast<size_t>(needed), '\0');
  std::vsnprintf(text.data(), text.size() + 1, format, again);
  va_end(again);
  return text;
}

inline std::string format_printf(const char* format, ...) __attribute__((format(printf, 1, 2)));
inline std::string format_printf(const char* format, ...) {
  va_list args;
  va_start(args, format);
  std::string text = vformat_printf(format, args);
  va_end(args);
  return text;
}

// `value` to `digits` significant digits ("%.<digits>g"): 0.000123, 1.5e+06, inf, nan.
inline std::string format_significant(double value, int digits = 6) {
  return format_printf("%.*g", digits, value);
}

}  // namespace camlab
