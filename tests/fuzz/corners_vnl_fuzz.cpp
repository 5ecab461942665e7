// corners.vnl text (calib/corners/corners_vnl.h), as `camlab calibrate --corners` and
// POST /v1/calibrations read it. The first byte picks the board size, so both the
// "rows per image" bookkeeping and the text are explored.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "calib/corners/corners_vnl.h"
#include "tests/fuzz/fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using camlab::fuzz::check;
  if (size < 1) return 0;
  const camlab::calib::BoardSpec board{1 + data[0] % 4, 1 + (data[0] / 4) % 4, 0.04};
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  auto views = camlab::calib::parse_corners_vnl(text, board);
  if (!views) {
    camlab::fuzz::check_error(views.error());
    return 0;
  }
  for (const auto& view : *views) {
    check(view.corners.size() == static_cast<size_t>(board.cols * board.rows),
          "a view without cols * rows corners");
    for (const auto& corner : view.corners) {
      if (!corner.present) continue;
      camlab::fuzz::check_finite(corner.x_px, "corner x");
      camlab::fuzz::check_finite(corner.y_px, "corner y");
      camlab::fuzz::check_finite(corner.weight, "corner weight");
    }
  }
  // What was read writes back and reads again to the same views.
  auto again = camlab::calib::parse_corners_vnl(camlab::calib::to_corners_vnl(*views), board);
  check(again.ok() && again->size() == views->size(), "corners.vnl does not round-trip");
  return 0;
}
