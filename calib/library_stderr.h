// What mrcal's C library prints on stderr (fprintf(stderr, ...): "Threw out some outliers
// ... going again" for each outlier-rejection round), routed into camlab's log at debug
// level, so a user sees camlab's own output only (CAMLAB_LOG=calib=debug shows the lines,
// as "calib: mrcal: ...").
//
// While at least one LibraryStderrCapture lives, fd 2 is a memfd and camlab's log writes
// to a duplicate of the real stderr (base/log.h, set_output_fd); when the last one ends,
// fd 2 is restored and the captured lines are logged. Captures nest and may overlap across
// threads (a count under a mutex): the first one redirects, the last one restores and logs
// every line captured meanwhile. Anything else that writes to fd 2 directly during a
// capture (another thread's library) is logged the same way, not lost. When a step fails
// (no memfd, dup2 refused), the capture does nothing and the output reaches stderr as
// before. At most 1 MiB and 200 lines are logged per capture; the rest are counted.
//
// Thread-safe.
#pragma once

namespace camlab::calib {

class LibraryStderrCapture {
 public:
  LibraryStderrCapture();
  ~LibraryStderrCapture();
  LibraryStderrCapture(const LibraryStderrCapture&) = delete;
  LibraryStderrCapture& operator=(const LibraryStderrCapture&) = delete;
};

}  // namespace camlab::calib
