#include "mock_device/render/charuco_pattern.h"

#include <algorithm>
#include <cmath>

#include "image/aruco_dictionary.h"

namespace camlab::mock {

namespace {

// Steps along one axis of a box beyond which it is complex: a box that spans more than a
// few marker cells is sampled anyway, and the test below is quadratic in the count.
constexpr size_t kMaxSteps = 8;

}  // namespace

Result<std::shared_ptr<const CharucoPattern>> CharucoPattern::create(const TargetSpec& spec) {
  image::ArucoDictionary dictionary;
  CAMLAB_ASSIGN(dictionary, image::find_aruco_dictionary(spec.dictionary));
  std::shared_ptr<CharucoPattern> p(new CharucoPattern());
  p->squares_cols_ = spec.corners_cols + 1;
  p->squares_rows_ = spec.corners_rows + 1;
  p->square_m_ = spec.square_m;
  p->inset_m_ = (spec.square_m - spec.marker_m) / 2;
  p->cells_ = dictionary.marker_bits + 2;
  p->cell_m_ = spec.marker_m / p->cells_;
  p->marker_of_square_.assign(static_cast<size_t>(p->squares_cols_ * p->squares_rows_), -1);
  int next_id = 0;
  for (int b = 0; b < p->squares_rows_; ++b)
    for (int a = 0; a < p->squares_cols_; ++a) {
      if ((a + b) % 2 == 0) continue;  // dark square
      std::vector<uint8_t> cells;
      CAMLAB_ASSIGN(cells, image::aruco_marker_cells(dictionary, next_id));
      p->marker_of_square_[static_cast<size_t>(b * p->squares_cols_ + a)] = next_id++;
      p->cells_by_marker_.push_back(std::move(cells));
    }
  return std::shared_ptr<const CharucoPattern>(std::move(p));
}

int CharucoPattern::marker_in_square(int a, int b) const {
  if (a < 0 || b < 0 || a >= squares_cols_ || b >= squares_rows_) return -1;
  return marker_of_square_[static_cast<size_t>(b * squares_cols_ + a)];
}

bool CharucoPattern::light_at(double u, double v) const {
  // Board coordinates from the board's top-left outer corner (OpenCV's object frame).
  const double x = u + square_m_, y = v + square_m_;
  const double fa = std::floor(x / square_m_), fb = std::floor(y / square_m_);
  if (fa < 0 || fb < 0 || fa >= squares_cols_ || fb >= squares_rows_) return true;  // quiet zone
  const int a = static_cast<int>(fa), b = static_cast<int>(fb);
  if ((a + b) % 2 == 0) return false;
  const int id = marker_of_square_[static_cast<size_t>(b * squares_cols_ + a)];
  // The marker's cell, counted from its top-left corner.
  const double cx = std::floor((x - a * square_m_ - inset_m_) / cell_m_);
  const double cy = std::floor((y - b * square_m_ - inset_m_) / cell_m_);
  if (cx < 0 || cy < 0 || cx >= cells_ || cy >= cells_) return true;  // the square's margin
  return cells_by_marker_[static_cast<size_t>(id)][static_cast<size_t>(cy * cells_ + cx)] != 0;
}

bool CharucoPattern::steps_in(double lo, double hi, int squares, std::vector<double>* steps) const {
  steps->clear();
  // Squares a whose extent [(a - 1) s, a s] meets [lo, hi]; clamped to the board, so a box
  // wholly in the quiet zone has none.
  const int a_lo = std::max(0, static_cast<int>(std::floor((lo + square_m_) / square_m_)));
  const int a_hi =
      std::min(squares - 1, static_cast<int>(std::floor((hi + square_m_) / square_m_)));
  auto add = [&](double at) {
    if (at > lo && at < hi) steps->push_back(at);
  };
  for (int a = a_lo; a <= a_hi; ++a) {
    const double side = (a - 1) * square_m_;  // the square's first side
    add(side);
    for (int k = 0; k <= cells_; ++k) add(side + inset_m_ + k * cell_m_);
    if (steps->size() > kMaxSteps) return false;
  }
  if (a_lo <= a_hi) add(a_hi * square_m_);  // the last square's far side
  std::sort(steps->begin(), steps->end());
  steps->erase(std::unique(steps->begin(), steps->end()), steps->end());
  return steps->size() <= kMaxSteps;
}

CharucoPattern::Structure CharucoPattern::structure_in(double u0, double u1, double v0,
                                                       double v1) const {
  Structure out;
  std::vector<double> su, sv;
  if (!steps_in(u0, u1, squares_cols_, &su) || !steps_in(v0, v1, squares_rows_, &sv)) return out;
  // The box's cells between the candidate steps, each one value: read at its centre.
  std::vector<double> bu = {u0}, bv = {v0};
  bu.insert(bu.end(), su.begin(), su.end());
  bv.insert(bv.end(), sv.begin(), sv.end());
  bu.push_back(u1);
  bv.push_back(v1);
  const size_t nu = bu.size() - 1, nv = bv.size() - 1;
  std::vector<uint8_t> value(nu * nv);
  for (size_t j = 0; j < nv; ++j)
    for (size_t i = 0; i < nu; ++i)
      value[j * nu + i] = light_at(0.5 * (bu[i] + bu[i + 1]), 0.5 * (bv[j] + bv[j + 1])) ? 1 : 0;
  // A candidate step is a step where the cells on its two sides differ in some row (or
  // column); grid lines between equal cells (a marker's neighbouring black cells) are not.
  std::vector<size_t> real_u, real_v;
  for (size_t i = 0; i + 1 < nu; ++i)
    for (size_t j = 0; j < nv; ++j)
      if (value[j * nu + i] != value[j * nu + i + 1]) {
        real_u.push_back(i);
        break;
      }
  for (size_t j = 0; j + 1 < nv; ++j)
    for (size_t i = 0; i < nu; ++i)
      if (value[j * nu + i] != value[(j + 1) * nu + i]) {
        real_v.push_back(j);
        break;
      }
  if (real_u.empty() && real_v.empty()) {
    out.kind = Structure::kConstant;
    out.negative_light = value[0] != 0;
  } else if (real_u.size() == 1 && real_v.empty()) {
    out.kind = Structure::kOneLine;
    out.negative_light = value[0] != 0;
    out.positive_light = value[nu - 1] != 0;
    out.e_u = 1;
    out.e0 = su[real_u[0]];
  } else if (real_v.size() == 1 && real_u.empty()) {
    out.kind = Structure::kOneLine;
    out.negative_light = value[0] != 0;
    out.positive_light = value[(nv - 1) * nu] != 0;
    out.e_v = 1;
    out.e0 = sv[real_v[0]];
  }
  return out;
}

}  // namespace camlab::mock
