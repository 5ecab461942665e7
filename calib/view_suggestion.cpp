// The next-view suggestion (view_suggestion.h): candidates from view_candidates.h, each
// scored by the projection uncertainty (uncertainty.h) of the solved problem with the
// candidate's predicted corners appended at its pose.
#include "calib/view_suggestion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "calib/library_stderr.h"
#include "calib/uncertainty.h"
#include "calib/uncertainty_update.h"
#include "calib/view_candidates.h"

namespace camlab::calib {

namespace {

std::string metres(double m) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f m", m);
  return buf;
}

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

Status check_inputs(const CalibrationData& data, const SuggestionOptions& o) {
  const BoardSpec& b = data.board;
  if (b.cols < 2 || b.rows < 2 || !(b.spacing_m > 0) || !std::isfinite(b.spacing_m))
    return make_error("invalid_argument",
                      "the board needs 2 x 2 or more inner corners and a positive spacing");
  if (data.imager_width_px <= 0 || data.imager_height_px <= 0)
    return make_error("invalid_argument", "the imager size is unknown (0 x 0 px)");
  if (o.grid_cols < 2 || o.grid_rows < 2 || o.grid_cols > 256 || o.grid_rows > 256)
    return make_error("invalid_argument", "the uncertainty grid needs 2..256 points per side");
  if (!std::isfinite(o.distance_m))
    return make_error("invalid_argument",
                      "the distance must be finite (<= 0: the working distance)");
  if (!(o.max_tilt_deg >= 0 && o.max_tilt_deg <= 70))
    return make_error("invalid_argument", "the largest tilt must be within 0..70 deg");
  if (!(o.min_corner_margin_px >= 0 &&
        4 * o.min_corner_margin_px < std::min(data.imager_width_px, data.imager_height_px)))
    return make_error("invalid_argument",
                      "the corner margin must be >= 0 px and under a quarter of the imager");
  if (!(o.nominal_fov_x_deg >= 10 && o.nominal_fov_x_deg <= 170))
    return make_error("invalid_argument", "the nominal field of view must be within 10..170 deg");
  if (!(o.opening_distance_m > 0 && std::isfinite(o.opening_distance_m)))
    return make_error("invalid_argument", "the opening distance must be a positive number of m");
  return {};
}

// The grid's pixels (pixel centres spanning the imager, row-major) as camera-frame points
// at `distance_m`; NaN where the model cannot unproject.
std::vector<std::array<double, 3>> grid_points(const LensModel& model, int cols, int rows,
                                               double distance_m) {
  std::vector<double> q;
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < cols; ++k) {
      q.push_back(k * (model.width_px - 1.0) / (cols - 1));
      q.push_back(r * (model.height_px - 1.0) / (rows - 1));
    }
  std::vector<std::array<double, 3>> out(q.size() / 2, {kNan, kNan, kNan});
  std::vector<char> valid;
  auto dirs = unproject_each(model, q, &valid);
  if (!dirs) return out;
  for (size_t i = 0; i < out.size(); ++i)
    if (valid[i])
      out[i] = {(*dirs)[3 * i] * distance_m, (*dirs)[3 * i + 1] * distance_m,
                (*dirs)[3 * i + 2] * distance_m};
  return out;
}

// Worst-direction stdev (px) at each grid point for `s` at detection noise sigma_px.
std::vector<double> grid_worst_px(const Solution& s,
                                  const std::vector<std::array<double, 3>>& points,
                                  double sigma_px) {
  std::vector<double> out(points.size(), kNan);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i][0])) continue;
    if (auto u = projection_uncertainty_of_point(s, points[i], false, sigma_px); u.ok())
      out[i] = u->worst_px();
  }
  return out;
}

// The largest finite value and its index; -1 when there is none.
std::pair<double, int> worst_of(const std::vector<double>& v) {
  std::pair<double, int> w{kNan, -1};
  for (size_t i = 0; i < v.size(); ++i)
    if (std::isfinite(v[i]) && (w.second < 0 || v[i] > w.first)) w = {v[i], static_cast<int>(i)};
  return w;
}

struct Tilt {
  double about_x_deg, about_y_deg;
};

ViewSuggestion suggestion_from(const CandidateView& c, const CalibrationData& data) {
  ViewSuggestion s;
  s.rt_cam_board = c.rt_cam_board;
  s.centre_x_px = c.centre_x_px;
  s.centre_y_px = c.centre_y_px;
  s.bounds_px = c.bounds_px;
  const size_t cols = static_cast<size_t>(data.board.cols),
               rows = static_cast<size_t>(data.board.rows);
  if (cols > 0 && rows > 0 && c.corners_px.size() >= 2 * cols * rows) {
    const std::array<size_t, 4> outer = {0, cols - 1, cols * rows - 1, cols * (rows - 1)};
    for (size_t k = 0; k < 4; ++k) {
      s.outline_px[2 * k] = c.corners_px[2 * outer[k]];
      s.outline_px[2 * k + 1] = c.corners_px[2 * outer[k] + 1];
    }
  }
  s.imager_width_px = data.imager_width_px;
  s.imager_height_px = data.imager_height_px;
  s.distance_m = c.distance_m;
  s.tilt_about_x_deg = c.tilt_about_x_deg;
  s.tilt_about_y_deg = c.tilt_about_y_deg;
  s.region = region_name(c.centre_x_px, c.centre_y_px, data.imager_width_px, data.imager_height_px);
  return s;
}

// Before the first solve: a pinhole of the nominal field of view, and a sequence that
// starts facing the camera at the centre, then tilts the board each way about both axes,
// then moves it towards the corners. The margin is wider than asked: the real lens is
// not the nominal one.
Result<ViewSuggestion> opening_view(const CalibrationData& data, const SuggestionOptions& o) {
  LensModel nominal;
  nominal.lensmodel = "LENSMODEL_PINHOLE";
  const double f = 0.5 * data.imager_width_px / std::tan(0.5 * o.nominal_fov_x_deg * M_PI / 180);
  nominal.intrinsics = {f, f, 0.5 * (data.imager_width_px - 1), 0.5 * (data.imager_height_px - 1)};
  nominal.width_px = data.imager_width_px;
  nominal.height_px = data.imager_height_px;
  SuggestionOptions wide = o;
  wide.min_corner_margin_px = std::max(
      o.min_corner_margin_px, 0.08 * std::min(data.imager_width_px, data.imager_height_px));
  const double t = std::min(o.max_tilt_deg, 30.0);
  struct Step {
    int gx, gy;
    Tilt tilt;
  };
  const Step sequence[] = {{0, 0, {0, 0}},  {0, 0, {t, 0}},  {0, 0, {0, t}},
                           {0, 0, {-t, 0}}, {0, 0, {0, -t}}, {-1, -1, {0, 0}},
                           {1, -1, {0, 0}}, {-1, 1, {0, 0}}, {1, 1, {0, 0}}};
  const size_t n = sizeof sequence / sizeof sequence[0];
  const Step& step = sequence[data.views.size() % n];
  auto c = place_towards(nominal, data.board, {0, 0}, step.gx, step.gy, o.opening_distance_m,
                         step.tilt.about_x_deg, step.tilt.about_y_deg, wide);
  if (!c)  // the step does not fit: the board facing the camera at the centre
    c = place_towards(nominal, data.board, {0, 0}, 0, 0, o.opening_distance_m, 0, 0, wide);
  if (!c)
    return make_error("no_candidate",
                      "the board does not fit on the imager at " + metres(o.opening_distance_m) +
                          " even facing the camera: hold it farther away or use a smaller board");
  ViewSuggestion s = suggestion_from(*c, data);
  s.opening = true;
  s.description = describe(s);
  return s;
}

}  // namespace

std::shared_ptr<const WarmStart> session_warm_start(const Solution& solution) {
  auto warm = std::make_shared<WarmStart>();
  warm->model = solution.model;
  warm->calobject_warp = solution.calobject_warp;
  int views = 0;
  for (int v : solution.views_used) views = std::max(views, v + 1);
  warm->rt_cam_board.resize(views);
  warm->outlier_corners.resize(views);
  for (size_t i = 0; i < solution.views_used.size(); ++i) {
    const int v = solution.views_used[i];
    warm->rt_cam_board[v] = solution.rt_cam_board[i];
    if (i < solution.view_downweighted.size() && solution.view_downweighted[i]) continue;
    for (const auto& r : solution.residuals)
      if (r.view == v && r.outlier) warm->outlier_corners[v].push_back(r.corner);
  }
  return warm;
}

Result<UncertaintyCoverage> uncertainty_coverage(const Solution& solution,
                                                 const SuggestionOptions& options) {
  if (!solution.covariance)
    return make_error("no_covariance", solution.covariance_error.empty()
                                           ? "the solve kept no covariance"
                                           : solution.covariance_error);
  CalibrationData shape;
  shape.board = solution.board;
  shape.imager_width_px = solution.model.width_px;
  shape.imager_height_px = solution.model.height_px;
  if (Status st = check_inputs(shape, options); !st) return st.error();
  UncertaintyCoverage out;
  out.cols = options.grid_cols;
  out.rows = options.grid_rows;
  out.distance_m = options.distance_m > 0 ? options.distance_m : working_distance_m(solution);
  if (!(out.distance_m > 0)) out.distance_m = options.opening_distance_m;
  const auto points = grid_points(solution.model, out.cols, out.rows, out.distance_m);
  out.worst_px = grid_worst_px(solution, points, 0);
  const auto [worst, at] = worst_of(out.worst_px);
  if (at < 0)
    return make_error("projection_failed", "the model cannot unproject any point of the grid");
  out.worst_of_grid_px = worst;
  out.worst_x_px = (at % out.cols) * (solution.model.width_px - 1.0) / (out.cols - 1);
  out.worst_y_px = (at / out.cols) * (solution.model.height_px - 1.0) / (out.rows - 1);
  return out;
}

Result<ViewSuggestion> suggest_next_view(const CalibrationData& data, const Solution* solution,
                                         const SuggestionOptions& options) {
  if (Status st = check_inputs(data, options); !st) return st.error();
  if (!solution) return opening_view(data, options);
  const Solution& s = *solution;
  if (!s.covariance)
    return make_error("no_covariance", s.covariance_error.empty() ? "the solve kept no covariance"
                                                                  : s.covariance_error);
  const LibraryStderrCapture quiet_mrcal;  // mrcal's chatter into the log (library_stderr.h)

  UncertaintyCoverage now;
  CAMLAB_ASSIGN(now, uncertainty_coverage(s, options));
  const auto points = grid_points(s.model, now.cols, now.rows, now.distance_m);
  UncertaintyPredictor predictor;
  CAMLAB_ASSIGN(predictor, UncertaintyPredictor::make(data, s));

  // Corners first, then edges, then the centre: the first among equals wins.
  const int regions[9][2] = {{-1, -1}, {1, -1}, {-1, 1}, {1, 1}, {0, -1},
                             {-1, 0},  {1, 0},  {0, 1},  {0, 0}};
  const double t = options.max_tilt_deg;
  std::vector<Tilt> tilts = {{0, 0}};
  if (t > 0) tilts.insert(tilts.end(), {{t, 0}, {-t, 0}, {0, t}, {0, -t}});
  std::optional<CandidateView> best;
  double best_worst = std::numeric_limits<double>::infinity();
  int placed = 0;
  std::string last_error;
  for (const auto& g : regions)
    for (const Tilt& tilt : tilts) {
      auto c = place_towards(s.model, data.board, s.calobject_warp, g[0], g[1], now.distance_m,
                             tilt.about_x_deg, tilt.about_y_deg, options);
      if (!c) continue;
      ++placed;
      auto grid = predictor.worst_px_with({c->rt_cam_board, c->corners_px, c->visible}, points);
      if (!grid) {
        last_error = grid.error().message;
        continue;
      }
      const double worst = worst_of(*grid).first;
      if (std::isfinite(worst) && worst < best_worst) {
        best_worst = worst;
        best = std::move(c);
      }
    }
  if (placed == 0)
    return make_error("no_candidate",
                      "no pose keeps the board visible at " + metres(now.distance_m) +
                          ": the board is too large for the imager at this distance");
  if (!best)
    return make_error("singular", "no candidate view gave a projection uncertainty: " + last_error);
  ViewSuggestion out = suggestion_from(*best, data);
  out.worst_now_px = now.worst_of_grid_px;
  out.predicted_worst_px = best_worst;
  out.description = describe(out);
  return out;
}

}  // namespace camlab::calib
