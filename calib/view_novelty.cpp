#include "calib/view_novelty.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/format.h"

namespace camlab::calib {

namespace {

// Of a view's present corners, the share another view must also show for the two to be
// the same pose: a view that shows mostly new corners (the board moved half out of the
// frame) adds what the earlier one lacked.
constexpr double kSharedFraction = 0.5;

struct Match {
  double rms_px = std::numeric_limits<double>::infinity();
  int shared = 0;
};

// Corner j of `view` against corner map(j) of `earlier`.
template <typename Map>
Match compare(const BoardView& view, const BoardView& earlier, Map map) {
  Match m;
  double sum_px2 = 0;
  for (size_t j = 0; j < view.corners.size(); ++j) {
    const auto& a = view.corners[j];
    const size_t k = map(j);
    if (!a.present || k >= earlier.corners.size() || !earlier.corners[k].present) continue;
    const auto& b = earlier.corners[k];
    sum_px2 += (a.x_px - b.x_px) * (a.x_px - b.x_px) + (a.y_px - b.y_px) * (a.y_px - b.y_px);
    ++m.shared;
  }
  if (m.shared > 0) m.rms_px = std::sqrt(sum_px2 / m.shared);
  return m;
}

}  // namespace

double near_duplicate_tolerance_px(const BoardView& view) {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const auto& c : view.corners) {
    if (!c.present) continue;
    x0 = std::min(x0, c.x_px);
    x1 = std::max(x1, c.x_px);
    y0 = std::min(y0, c.y_px);
    y1 = std::max(y1, c.y_px);
  }
  const double board_diagonal_px = x1 > x0 ? std::hypot(x1 - x0, y1 - y0) : 0;
  return std::max(1.0, 0.005 * board_diagonal_px);
}

std::optional<NearDuplicate> find_near_duplicate(const CalibrationData& data,
                                                 const BoardView& view) {
  const int present = view.present_count();
  if (present == 0) return std::nullopt;
  const double tolerance_px = near_duplicate_tolerance_px(view);
  const bool labels_can_turn = view.detector != "charuco";
  for (size_t v = 0; v < data.views.size(); ++v) {
    const BoardView& earlier = data.views[v];
    const size_t n = earlier.corners.size();
    Match best = compare(view, earlier, [](size_t j) { return j; });
    bool rotated = false;
    if (labels_can_turn && n == view.corners.size()) {
      const Match turned = compare(view, earlier, [n](size_t j) { return n - 1 - j; });
      if (turned.rms_px < best.rms_px) {
        best = turned;
        rotated = true;
      }
    }
    if (best.shared >= kSharedFraction * present && best.rms_px <= tolerance_px)
      return NearDuplicate{static_cast<int>(v), best.rms_px, best.shared, rotated};
  }
  return std::nullopt;
}

std::string describe(const NearDuplicate& duplicate, const CalibrationData& data) {
  const std::string& name = data.views[static_cast<size_t>(duplicate.view)].name;
  return format_printf(
      "the board sits where it sat in view %d%s: %d corners %.1f px apart RMS; move or tilt "
      "it (a new pose adds geometry, a repeat does not)",
      duplicate.view, name.empty() ? "" : (" (" + name + ")").c_str(), duplicate.shared_corners,
      duplicate.rms_px);
}

}  // namespace camlab::calib
