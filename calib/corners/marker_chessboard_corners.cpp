#include "calib/corners/marker_chessboard_corners.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/corners/image_8bit.h"
#include "calib/corners/saddle_corners.h"
#include "calib/corners/saddle_point.h"

namespace camlab::calib {

namespace {

constexpr double kWindowShare = 0.4;  // of the distance to the nearest lattice neighbour
constexpr double kMaxWindowPx = 12;
constexpr double kMinWindowPx = 2.5;
// The window may shrink to fit the image down to this share of its usual size: a lattice
// corner snapped a few pixels off at the
// imager's edge, refined in a window the border squeezed to 6 px of a 50-px spacing,
// settled 7 px from the truth (marker_chessboard_bench, view 12 of --seed 9's scene).
constexpr double kMinWindowShare = 0.5;
constexpr double kMaxMoveShare = 0.5;  // of the window: a larger move found another corner
// A marker's centre must differ from its cell's body by this share of the difference
// between the dark and the light cells' bodies, towards the other colour.
constexpr double kMarkerContrastShare = 0.5;

double sample(const cv::Mat& gray, cv::Point2d p) {
  const int x0 = static_cast<int>(std::floor(p.x)), y0 = static_cast<int>(std::floor(p.y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= gray.cols || y0 + 1 >= gray.rows) return NAN;
  const double a = p.x - x0, b = p.y - y0;
  const float* r0 = gray.ptr<float>(y0);
  const float* r1 = gray.ptr<float>(y0 + 1);
  return (1 - b) * ((1 - a) * r0[x0] + a * r0[x0 + 1]) + b * ((1 - a) * r1[x0] + a * r1[x0 + 1]);
}

// Where the diagonals p00-p11 and p01-p10 cross: the centre of the square the
// quadrilateral images (a homography keeps the crossing of the diagonals).
cv::Point2d diagonal_crossing(cv::Point2d p00, cv::Point2d p11, cv::Point2d p01, cv::Point2d p10) {
  const cv::Point2d d1 = p11 - p00, d2 = p10 - p01;
  const double den = d1.x * d2.y - d1.y * d2.x;
  if (std::fabs(den) < 1e-12) return 0.25 * (p00 + p01 + p10 + p11);
  const cv::Point2d w = p01 - p00;
  const double t = (w.x * d2.y - w.y * d2.x) / den;
  return p00 + t * d1;
}

// The named corners checked against each other by id: each corner is predicted from its
// named neighbours along the board's rows and columns (the midpoint of the two beside it,
// or a straight step from the two before it on either side); its deviation is the
// largest of those predictions' misses over the step they span. The worst corner above
// kMaxStepMiss is dropped and the rest checked again, until none is: a lattice that
// skipped a column at the imager's edge names a corner one over, a step off where its
// neighbours put it, while perspective and distortion bend a row by a few hundredths of
// a step. A corner no neighbour predicts is dropped too: nothing vouches for its id.
constexpr double kMaxStepMiss = 0.2;

int drop_inconsistent(int cols, int rows, std::vector<int>* ids, std::vector<cv::Point2d>* px) {
  int dropped = 0;
  for (;;) {
    std::vector<int> at(static_cast<size_t>(cols * rows), -1);
    for (size_t k = 0; k < ids->size(); ++k)
      at[static_cast<size_t>((*ids)[k])] = static_cast<int>(k);
    auto get = [&](int i, int j) -> const cv::Point2d* {
      if (i < 0 || j < 0 || i >= cols || j >= rows) return nullptr;
      const int k = at[static_cast<size_t>(j * cols + i)];
      return k < 0 ? nullptr : &(*px)[static_cast<size_t>(k)];
    };
    double worst = -1;
    size_t worst_k = 0;
    for (size_t k = 0; k < ids->size(); ++k) {
      const int i = (*ids)[k] % cols, j = (*ids)[k] / cols;
      const cv::Point2d p = (*px)[k];
      double miss = -1;  // -1: no prediction
      for (const auto& [di, dj] : {std::array{1, 0}, std::array{0, 1}}) {
        const cv::Point2d *m1 = get(i - di, j - dj), *p1 = get(i + di, j + dj),
                          *m2 = get(i - 2 * di, j - 2 * dj), *p2 = get(i + 2 * di, j + 2 * dj);
        if (m1 && p1)
          miss = std::max(miss, cv::norm(p - 0.5 * (*m1 + *p1)) / (0.5 * cv::norm(*p1 - *m1)));
        if (m1 && m2) miss = std::max(miss, cv::norm(p - (2.0 * *m1 - *m2)) / cv::norm(*m1 - *m2));
        if (p1 && p2) miss = std::max(miss, cv::norm(p - (2.0 * *p1 - *p2)) / cv::norm(*p1 - *p2));
      }
      if (miss < 0) miss = 1e9;
      if (miss > worst) worst = miss, worst_k = k;
    }
    if (worst <= kMaxStepMiss) return dropped;
    ids->erase(ids->begin() + static_cast<long>(worst_k));
    px->erase(px->begin() + static_cast<long>(worst_k));
    ++dropped;
  }
}

// A grid cell: the square between corners (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1).
struct Cell {
  bool complete = false;            // all four corners in the grid
  double centre = NAN, body = NAN;  // grey values
  cv::Point2d centre_px;
};

}  // namespace

Result<MarkerChessboardCorners> name_by_markers(const cv::Mat& image,
                                                const std::vector<cv::Point2i>& ij,
                                                const std::vector<cv::Point2d>& px, int cols,
                                                int rows) {
  if (cols < 3 || rows < 3)
    return make_error("invalid_argument",
                      "a chessboard with markers needs at least 3 x 3 inner corners; got " +
                          std::to_string(cols) + "x" + std::to_string(rows));
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("invalid_argument", "the image must be 8- or 16-bit grey");
  if (ij.size() != px.size() || ij.size() < 4)
    return make_error("board_not_found", "the grid has fewer than 4 corners");
  // The grid, dense over its bounding box: index of the corner or -1.
  int i0 = ij[0].x, i1 = ij[0].x, j0 = ij[0].y, j1 = ij[0].y;
  for (const auto& c : ij) {
    i0 = std::min(i0, c.x), i1 = std::max(i1, c.x);
    j0 = std::min(j0, c.y), j1 = std::max(j1, c.y);
  }
  const int gw = i1 - i0 + 1, gh = j1 - j0 + 1;
  if (gw > 4 * (cols + rows) || gh > 4 * (cols + rows))
    return make_error("board_not_found", "the grid is far larger than the board");
  std::vector<int> at(static_cast<size_t>(gw * gh), -1);
  for (size_t k = 0; k < ij.size(); ++k)
    at[static_cast<size_t>((ij[k].y - j0) * gw + (ij[k].x - i0))] = static_cast<int>(k);
  auto corner = [&](int i, int j) {  // grid-relative indices
    if (i < 0 || j < 0 || i >= gw || j >= gh) return -1;
    return at[static_cast<size_t>(j * gw + i)];
  };

  cv::Mat gray;
  image.convertTo(gray, CV_32F);
  const int cw = gw - 1, ch = gh - 1;
  std::vector<Cell> cells(static_cast<size_t>(std::max(0, cw * ch)));
  double sum_body = 0;
  int n_body = 0;
  for (int j = 0; j < ch; ++j)
    for (int i = 0; i < cw; ++i) {
      const int k00 = corner(i, j), k10 = corner(i + 1, j), k01 = corner(i, j + 1),
                k11 = corner(i + 1, j + 1);
      if (k00 < 0 || k10 < 0 || k01 < 0 || k11 < 0) continue;
      Cell& cell = cells[static_cast<size_t>(j * cw + i)];
      const cv::Point2d p00 = px[k00], p10 = px[k10], p01 = px[k01], p11 = px[k11];
      cell.centre_px = diagonal_crossing(p00, p11, p10, p01);
      cell.centre = sample(gray, cell.centre_px);
      double body = 0;
      for (const cv::Point2d& p : {p00, p01, p10, p11})
        body += 0.25 * sample(gray, cell.centre_px + 0.5 * (p - cell.centre_px));
      cell.body = body;
      cell.complete = std::isfinite(cell.centre) && std::isfinite(cell.body);
      if (cell.complete) {
        sum_body += body;
        ++n_body;
      }
    }
  if (n_body < 3) return make_error("board_not_found", "the grid has fewer than 3 whole cells");
  const double threshold = sum_body / n_body;  // neighbouring cells alternate
  double dark = 0, light = 0;
  int nd = 0, nl = 0;
  for (const Cell& cell : cells) {
    if (!cell.complete) continue;
    if (cell.body < threshold)
      dark += cell.body, ++nd;
    else
      light += cell.body, ++nl;
  }
  if (nd == 0 || nl == 0) return make_error("board_not_found", "the grid's cells are one colour");
  dark /= nd;
  light /= nl;
  const double margin = kMarkerContrastShare * (light - dark);
  auto cell_at = [&](int i, int j) -> const Cell* {
    if (i < 0 || j < 0 || i >= cw || j >= ch) return nullptr;
    const Cell* c = &cells[static_cast<size_t>(j * cw + i)];
    return c->complete ? c : nullptr;
  };
  auto is_light = [&](const Cell& cell) { return cell.body >= threshold; };
  auto has_marker = [&](const Cell& cell) {
    return is_light(cell) ? cell.centre < cell.body - margin : cell.centre > cell.body + margin;
  };

  // The light marker cell with a dark marker cell beside it along each grid axis.
  int found = 0, wi = -1, wj = -1, step_i = 0, step_j = 0;
  for (int j = 0; j < ch; ++j)
    for (int i = 0; i < cw; ++i) {
      const Cell* w = cell_at(i, j);
      if (!w || !is_light(*w) || !has_marker(*w)) continue;
      int si = 0, sj = 0;
      for (int s : {-1, 1}) {
        const Cell* n = cell_at(i + s, j);
        if (n && !is_light(*n) && has_marker(*n)) si = si == 0 ? s : 2;
        n = cell_at(i, j + s);
        if (n && !is_light(*n) && has_marker(*n)) sj = sj == 0 ? s : 2;
      }
      if (si == 0 || sj == 0 || si == 2 || sj == 2) continue;
      ++found;
      wi = i, wj = j, step_i = si, step_j = sj;
    }
  if (found == 0)
    return make_error("board_not_found",
                      "the grid holds no marker triple (a view must show the board's three "
                      "marker squares)");
  if (found > 1)
    return make_error("board_not_found", "the grid holds " + std::to_string(found) +
                                             " marker triples: not one board with markers");

  // Board +x and -y among the two neighbours: seen from the front, the board's +x turned by
  // +90 deg in the image (y down) is its +y, so x cross y > 0.
  const Cell& w = *cell_at(wi, wj);
  const cv::Point2d to_i = cell_at(wi + step_i, wj)->centre_px - w.centre_px;
  const cv::Point2d to_j = cell_at(wi, wj + step_j)->centre_px - w.centre_px;
  // Candidate: +x towards the neighbour along grid i, +y away from the one along grid j.
  const double cross = to_i.x * (-to_j.y) - to_i.y * (-to_j.x);
  // Grid steps (di, dj) of board +x and of board -y.
  const cv::Point2i ex = cross > 0 ? cv::Point2i(step_i, 0) : cv::Point2i(0, step_j);
  const cv::Point2i emy = cross > 0 ? cv::Point2i(0, step_j) : cv::Point2i(step_i, 0);
  const auto [a, b] = marker_square(cols, rows);

  MarkerChessboardCorners out;
  out.cols = cols;
  out.rows = rows;
  out.grid_corners = static_cast<int>(ij.size());
  for (int gj = 0; gj < gh; ++gj)
    for (int gi = 0; gi < gw; ++gi) {
      const int k = corner(gi, gj);
      if (k < 0) continue;
      // Offset from the light marker cell's centre, in cells; that centre is board point
      // (a - 0.5, b - 0.5) in inner-corner units (square (a, b) spans [a - 1, a] x [b - 1, b]).
      const double gx = gi - (wi + 0.5), gy = gj - (wj + 0.5);
      const double x = (a - 0.5) + gx * ex.x + gy * ex.y;
      const double y = (b - 0.5) - (gx * emy.x + gy * emy.y);
      const int bi = static_cast<int>(std::lround(x)), bj = static_cast<int>(std::lround(y));
      if (bi < 0 || bj < 0 || bi >= cols || bj >= rows) {
        ++out.off_board;
        continue;
      }
      const cv::Point2d start = px[k];
      double nearest_px = 1e30;
      for (const auto& [di, dj] :
           {std::array{1, 0}, std::array{-1, 0}, std::array{0, 1}, std::array{0, -1}}) {
        const int n = corner(gi + di, gj + dj);
        if (n >= 0) nearest_px = std::min(nearest_px, cv::norm(px[n] - start));
      }
      const double to_border_px =
          std::min({start.x, start.y, image.cols - 1 - start.x, image.rows - 1 - start.y}) - 1.0;
      const double usual_px = std::min(kMaxWindowPx, kWindowShare * nearest_px);
      const double window_px = std::min(usual_px, to_border_px);
      if (window_px < kMinWindowPx || window_px < kMinWindowShare * usual_px) {
        ++out.dropped;
        continue;
      }
      auto refined = refine_saddle_point(gray, start, window_px, kMaxMoveShare * window_px);
      if (!refined) {
        ++out.dropped;
        continue;
      }
      out.ids.push_back(bj * cols + bi);
      out.corners_px.push_back(refined->corner_px);
    }
  out.inconsistent = drop_inconsistent(cols, rows, &out.ids, &out.corners_px);
  if (out.ids.empty()) return make_error("board_not_found", "no corner of the grid was refined");
  return out;
}

Result<MarkerChessboardCorners> find_marker_chessboard(const cv::Mat& image, int cols, int rows) {
  if (cols < 3 || rows < 3)
    return make_error("invalid_argument",
                      "a chessboard with markers needs at least 3 x 3 inner corners; got " +
                          std::to_string(cols) + "x" + std::to_string(rows));
  // The lattice may start anywhere on the board: it spans the board from any seed.
  auto lattice = find_saddle_lattice(image, std::max(cols, rows) + 1, 9);
  Result<MarkerChessboardCorners> named =
      lattice ? name_by_markers(image, lattice->ij, lattice->corners_px, cols, rows)
              : Result<MarkerChessboardCorners>(lattice.error());
  if (named) return named;
  // Second chance: OpenCV's grid around its own markers.
  if (image.depth() != CV_8U && image.depth() != CV_16U) return named;
  cv::Mat grid, meta;
  try {
    if (!cv::findChessboardCornersSB(stretch_to_8bit(image), cv::Size(4, 4), grid,
                                     cv::CALIB_CB_LARGER | cv::CALIB_CB_MARKER, meta))
      return named;
  } catch (const cv::Exception&) {
    return named;
  }
  if (meta.rows * meta.cols != static_cast<int>(grid.total())) return named;
  grid = grid.reshape(2, meta.rows * meta.cols);
  std::vector<cv::Point2i> ij;
  std::vector<cv::Point2d> px;
  for (int k = 0; k < meta.rows * meta.cols; ++k) {
    const cv::Point2f p = grid.at<cv::Point2f>(k);
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    ij.emplace_back(k % meta.cols, k / meta.cols);
    px.emplace_back(p);
  }
  auto second = name_by_markers(image, ij, px, cols, rows);
  return second ? second : named;
}

}  // namespace camlab::calib
