#include "calib/view_candidates.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace camlab::calib {

namespace {

constexpr double kRadPerDeg = M_PI / 180;

}  // namespace

std::optional<std::array<double, 6>> board_pose_at(const LensModel& model, const BoardSpec& board,
                                                   double x_px, double y_px, double distance_m,
                                                   double tilt_about_x_deg,
                                                   double tilt_about_y_deg) {
  auto dir = unproject(model, {x_px, y_px});
  if (!dir) return std::nullopt;
  cv::Vec3d z((*dir)[0], (*dir)[1], (*dir)[2]);
  z /= cv::norm(z);
  // Facing along the ray: board z along it (away from the camera), board x as close to the
  // image's x as the ray allows, board y (down the board) completing a right-handed frame.
  cv::Vec3d x = cv::Vec3d(1, 0, 0) - z * z[0];
  if (cv::norm(x) < 1e-9) return std::nullopt;
  x /= cv::norm(x);
  const cv::Vec3d y = z.cross(x);
  const cv::Matx33d aim(x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]);
  // A rotation by +a about the board's x axis sends its bottom (+y) away from the camera
  // (+z), so "top away" is -a; one by +b about its y axis sends its right side (+x)
  // towards the camera, so "right away" is -b.
  cv::Matx33d tilt_x, tilt_y;
  cv::Rodrigues(cv::Vec3d(-tilt_about_x_deg * kRadPerDeg, 0, 0), tilt_x);
  cv::Rodrigues(cv::Vec3d(0, -tilt_about_y_deg * kRadPerDeg, 0), tilt_y);
  const cv::Matx33d R = aim * tilt_x * tilt_y;
  const cv::Vec3d half(0.5 * (board.cols - 1) * board.spacing_m,
                       0.5 * (board.rows - 1) * board.spacing_m, 0);
  const cv::Vec3d t = z * distance_m - R * half;
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  return std::array<double, 6>{r[0], r[1], r[2], t[0], t[1], t[2]};
}

std::optional<CandidateView> observe_candidate(const LensModel& model, const BoardSpec& board,
                                               const std::array<double, 6>& rt,
                                               const std::array<double, 2>& calobject_warp,
                                               double margin_px) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  const int n = board.cols * board.rows;
  std::vector<double> p(3 * static_cast<size_t>(n));
  for (int j = 0; j < board.rows; ++j)
    for (int i = 0; i < board.cols; ++i) {
      // mrcal's board warp (as project_board_corner): a paraboloid along each board axis.
      const double xr = 2.0 * i / (board.cols - 1) - 1, yr = 2.0 * j / (board.rows - 1) - 1;
      const cv::Vec3d pb(i * board.spacing_m, j * board.spacing_m,
                         calobject_warp[0] * (1 - xr * xr) + calobject_warp[1] * (1 - yr * yr));
      const cv::Vec3d q = R * pb + cv::Vec3d(rt[3], rt[4], rt[5]);
      const size_t k = static_cast<size_t>(j) * board.cols + i;
      p[3 * k] = q[0];
      p[3 * k + 1] = q[1];
      p[3 * k + 2] = q[2];
    }
  auto q = project(model, p);
  if (!q) return std::nullopt;
  CandidateView v;
  v.rt_cam_board = rt;
  v.corners_px = std::move(*q);
  v.corners_cam = std::move(p);
  v.visible.assign(n, 0);
  const double x_max = model.width_px - 1 - margin_px, y_max = model.height_px - 1 - margin_px;
  v.bounds_px = {1e300, 1e300, -1e300, -1e300};
  for (int k = 0; k < n; ++k) {
    const double x = v.corners_px[2 * k], y = v.corners_px[2 * k + 1];
    v.visible[k] = v.corners_cam[3 * k + 2] > 0 && std::isfinite(x) && std::isfinite(y) &&
                   x >= margin_px && y >= margin_px && x <= x_max && y <= y_max;
    if (!std::isfinite(x) || !std::isfinite(y)) continue;
    v.bounds_px = {std::min(v.bounds_px[0], x), std::min(v.bounds_px[1], y),
                   std::max(v.bounds_px[2], x), std::max(v.bounds_px[3], y)};
  }
  const cv::Vec3d centre = R * cv::Vec3d(0.5 * (board.cols - 1) * board.spacing_m,
                                         0.5 * (board.rows - 1) * board.spacing_m, 0) +
                           cv::Vec3d(rt[3], rt[4], rt[5]);
  v.distance_m = cv::norm(centre);
  if (auto c = project(model, {centre[0], centre[1], centre[2]}); c.ok()) {
    v.centre_x_px = (*c)[0];
    v.centre_y_px = (*c)[1];
  }
  return v;
}

bool detectable(const CandidateView& view, bool whole_board_required) {
  const int n = static_cast<int>(view.visible.size());
  const int seen = static_cast<int>(std::count(view.visible.begin(), view.visible.end(), 1));
  return whole_board_required ? seen == n : 2 * seen >= n;
}

namespace {

// The corners the detector sees must also be where the model is one-to-one: each visible
// corner's pixel unprojects back to its own direction (within 1e-5 rad).
bool one_to_one(const LensModel& model, CandidateView* v) {
  std::vector<char> valid;
  auto dirs = unproject_each(model, v->corners_px, &valid);
  if (!dirs) return false;
  for (size_t k = 0; k < v->visible.size(); ++k) {
    if (!v->visible[k]) continue;
    const double* p = &v->corners_cam[3 * k];
    const double* d = &(*dirs)[3 * k];
    const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const double dot = valid[k] ? (p[0] * d[0] + p[1] * d[1] + p[2] * d[2]) / norm : 0.0;
    if (!(dot > std::cos(1e-5))) v->visible[k] = 0;
  }
  return true;
}

}  // namespace

std::optional<CandidateView> place_towards(const LensModel& model, const BoardSpec& board,
                                           const std::array<double, 2>& calobject_warp, int gx,
                                           int gy, double distance_m, double tilt_about_x_deg,
                                           double tilt_about_y_deg,
                                           const SuggestionOptions& options) {
  const double cx = 0.5 * (model.width_px - 1), cy = 0.5 * (model.height_px - 1);
  auto try_at = [&](double x, double y) -> std::optional<CandidateView> {
    auto rt = board_pose_at(model, board, x, y, distance_m, tilt_about_x_deg, tilt_about_y_deg);
    if (!rt) return std::nullopt;
    auto v = observe_candidate(model, board, *rt, calobject_warp, options.min_corner_margin_px);
    if (!v || !detectable(*v, options.whole_board_required)) return std::nullopt;
    return v;
  };
  // Bisection of a segment from a placement the detector sees (lo) to one it does not
  // (hi): ~0.1% of the segment. The board stays seen up to one place along the way and
  // not beyond (it leaves the imager on the region's side), so the end is the farthest.
  auto push = [&](double* x, double* y, double x_end, double y_end) {
    if (try_at(x_end, y_end)) {
      *x = x_end;
      *y = y_end;
      return;
    }
    double lo = 0, hi = 1;
    for (int k = 0; k < 10; ++k) {
      const double mid = 0.5 * (lo + hi);
      (try_at(*x + mid * (x_end - *x), *y + mid * (y_end - *y)) ? lo : hi) = mid;
    }
    *x += lo * (x_end - *x);
    *y += lo * (y_end - *y);
  };
  double x = cx, y = cy;
  if (!try_at(x, y)) return std::nullopt;
  // Towards the region along the line from the centre, then along each axis on its own
  // (a board whose aspect is not the imager's reaches one edge first).
  push(&x, &y, cx + gx * cx, cy + gy * cy);
  if (gx != 0) push(&x, &y, cx + gx * cx, y);
  if (gy != 0) push(&x, &y, x, cy + gy * cy);
  // The corners must be where the model is one-to-one; back towards the centre if not.
  for (int k = 0; k < 10; ++k) {
    auto v = try_at(x, y);
    if (v && one_to_one(model, &*v) && detectable(*v, options.whole_board_required)) {
      v->tilt_about_x_deg = tilt_about_x_deg;
      v->tilt_about_y_deg = tilt_about_y_deg;
      return v;
    }
    x = cx + 0.9 * (x - cx);
    y = cy + 0.9 * (y - cy);
  }
  return std::nullopt;
}

std::string region_name(double x_px, double y_px, int width_px, int height_px) {
  const int col = x_px < width_px / 3.0 ? 0 : x_px > 2 * width_px / 3.0 ? 2 : 1;
  const int row = y_px < height_px / 3.0 ? 0 : y_px > 2 * height_px / 3.0 ? 2 : 1;
  static const char* const kNames[3][3] = {{"top_left", "top", "top_right"},
                                           {"left", "centre", "right"},
                                           {"bottom_left", "bottom", "bottom_right"}};
  return kNames[row][col];
}

std::string describe(const ViewSuggestion& s) {
  std::string where = s.region;
  std::replace(where.begin(), where.end(), '_', ' ');
  std::string tilt;
  char buf[160];
  auto add_tilt = [&](double deg, const char* positive_edge, const char* negative_edge) {
    if (std::fabs(deg) < 0.5) return;
    std::snprintf(buf, sizeof buf, "%s%s edge tilted %.0f deg away", tilt.empty() ? "" : ", ",
                  deg > 0 ? positive_edge : negative_edge, std::fabs(deg));
    tilt += buf;
  };
  add_tilt(s.tilt_about_x_deg, "top", "bottom");
  add_tilt(s.tilt_about_y_deg, "right", "left");
  if (tilt.empty()) tilt = "facing the camera";
  std::snprintf(buf, sizeof buf, "board %.2f m away, centred at (%.0f, %.0f) px (%s), ",
                s.distance_m, s.centre_x_px, s.centre_y_px, where.c_str());
  std::string out = std::string(s.opening ? "Opening view: " : "Next view: ") + buf + tilt;
  if (!s.opening) {
    std::snprintf(buf, sizeof buf, "; worst uncertainty %.3f px now, %.3f px predicted",
                  s.worst_now_px, s.predicted_worst_px);
    out += buf;
  }
  return out;
}

}  // namespace camlab::calib
