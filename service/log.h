// Log lines on stderr: "camlabd <UTC time> <level>: message". One write per line, so
// lines from threads never interleave.
//
// Thread-safe.
#pragma once

namespace camlab::service {

void log_info(const char* format, ...) __attribute__((format(printf, 1, 2)));
void log_warning(const char* format, ...) __attribute__((format(printf, 1, 2)));
void log_error(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace camlab::service
