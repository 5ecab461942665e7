#include "calib/corners/saddle_corners.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "calib/corners/board_ring.h"
#include "calib/corners/image_8bit.h"
#include "calib/corners/tone_sampling.h"

namespace camlab::calib {

namespace {

// Blur of the coarse image before the Hessian (coarse-level px): an X-junction's
// response peaks at its centre for any blur well under the corner spacing, and the
// coarse pass must still see boards whose corners are 8 px apart at that level.
constexpr double kBlurSigmaPx = 1.2;
// The coarse pass starts at the deepest pyramid level whose short side keeps this many
// pixels (1280x800: half resolution; 6000x4000: an eighth), at most level 3.
constexpr int kMinCoarseSidePx = 360;
constexpr int kMaxLevel = 3;
// A candidate is taken when it lies within this share of the local corner spacing of
// the position its grid neighbours predict.
constexpr double kSnapShare = 0.3;
// The full-resolution cornerSubPix window's half-width, as a share of the view's smallest
// corner spacing: 0.45 (the other detectors' value) reached across to the neighbouring
// squares' edges on steep views, whose corners it pulled by up to 1.3 px; 0.35 keeps the
// example views' worst corner within 0.28 px of the truth (docs/calibration.md).
constexpr double kRefineWindowShare = 0.35;

struct Candidate {
  cv::Point2f p;              // coarse-level px, sub-pixel
  float response = 0;         // -det(H)
  float checked_radius = -1;  // radius of the last X-junction test (px); -1: never tested
  bool x_junction = false;
};

// The coarse level's blurred image (CV_32F, 0..1) and its saddle response -det(H) =
// Ixy^2 - Ixx Iyy: zero on straight edges (a rank-1 Hessian), strongly positive at the
// centre of an X-junction, where the intensity curves up along one diagonal and down
// along the other.
struct Response {
  cv::Mat blurred;
  cv::Mat saddle;
};

Response saddle_response(const cv::Mat& gray8) {
  Response r;
  gray8.convertTo(r.blurred, CV_32F, 1.0 / 255);
  cv::GaussianBlur(r.blurred, r.blurred, cv::Size(), kBlurSigmaPx);
  cv::Mat ixx, iyy, ixy;
  cv::Sobel(r.blurred, ixx, CV_32F, 2, 0, 3);
  cv::Sobel(r.blurred, iyy, CV_32F, 0, 2, 3);
  cv::Sobel(r.blurred, ixy, CV_32F, 1, 1, 3);
  r.saddle = ixy.mul(ixy) - ixx.mul(iyy);
  return r;
}

// Local maxima of the saddle response (3x3), strongest first, at most `keep`, none weaker
// than 2% of the strongest `board_corners / 2`-th: a board's corners respond alike, and
// the faint saddles of texture and noise are left out. Positions get a parabola's
// sub-pixel offset along x and y.
std::vector<Candidate> find_candidates(const cv::Mat& saddle, int board_corners, int keep) {
  cv::Mat dilated;
  cv::dilate(saddle, dilated, cv::Mat());
  std::vector<Candidate> out;
  for (int y = 2; y < saddle.rows - 2; ++y) {
    const float* s = saddle.ptr<float>(y);
    const float* d = dilated.ptr<float>(y);
    for (int x = 2; x < saddle.cols - 2; ++x)
      if (s[x] > 0 && s[x] >= d[x]) out.push_back({cv::Point2f(x, y), s[x]});
  }
  std::sort(out.begin(), out.end(),
            [](const Candidate& a, const Candidate& b) { return a.response > b.response; });
  if (out.empty()) return out;
  const float reference = out[std::min<size_t>(out.size() - 1, board_corners / 2)].response;
  while (!out.empty() &&
         (static_cast<int>(out.size()) > keep || out.back().response < 0.02f * reference))
    out.pop_back();
  for (auto& c : out) {
    const int x = static_cast<int>(c.p.x), y = static_cast<int>(c.p.y);
    auto offset = [](float m, float c0, float p) {
      const float den = m - 2 * c0 + p;
      return den < 0 ? std::clamp(0.5f * (m - p) / den, -0.5f, 0.5f) : 0.f;
    };
    c.p.x += offset(saddle.at<float>(y, x - 1), c.response, saddle.at<float>(y, x + 1));
    c.p.y += offset(saddle.at<float>(y - 1, x), c.response, saddle.at<float>(y + 1, x));
  }
  return out;
}

// Whether the blurred image around p shows an X-junction: on a circle of `radius` px, the
// intensity changes sign (about its mean) exactly four times, dark and bright sectors
// alternating. An L-junction at the board's outer edge, a blob or a line end has two
// changes or none. Samples within 15% of the range of the mean are left out, so noise at
// a sector's border cannot add changes.
bool is_x_junction(const cv::Mat& blurred, cv::Point2f p, float radius) {
  constexpr int kSamples = 24;
  std::array<float, kSamples> v{};
  float mean = 0, lo = 1e9f, hi = -1e9f;
  for (int k = 0; k < kSamples; ++k) {
    const float a = static_cast<float>(2 * M_PI * k / kSamples);
    v[k] = sample_bilinear(blurred, p.x + radius * std::cos(a), p.y + radius * std::sin(a));
    mean += v[k] / kSamples;
    lo = std::min(lo, v[k]);
    hi = std::max(hi, v[k]);
  }
  const float dead = 0.15f * (hi - lo);
  if (!(hi - lo > 0.02f)) return false;  // no contrast: under 2% of full scale
  int first = 0, last = 0, changes = 0;
  for (int k = 0; k < kSamples; ++k) {
    const float d = v[k] - mean;
    const int sign = d > dead ? 1 : (d < -dead ? -1 : 0);
    if (sign == 0) continue;
    if (first == 0) first = sign;
    if (last != 0 && sign != last) ++changes;
    last = sign;
  }
  if (first != 0 && last != first) ++changes;  // around the circle's closing point
  return changes == 4;
}

// Whether the segment p-q runs along a black-white edge of the board, as it does between
// neighbours along a row or column: either side of its midpoint differs by half the
// local contrast. Between diagonal neighbours the midpoint is a square's centre, alike on
// both sides. It keeps a skewed view's diagonal from being taken as a grid axis (a basis
// that spans the same corners, sheared).
bool along_edge(const cv::Mat& blurred, cv::Point2f p, cv::Point2f q, float contrast) {
  const cv::Point2f m = 0.5f * (p + q), d = q - p;
  const cv::Point2f n = cv::Point2f(-d.y, d.x) * 0.2f;
  const float a = sample_bilinear(blurred, m.x + n.x, m.y + n.y),
              b = sample_bilinear(blurred, m.x - n.x, m.y - n.y);
  return std::fabs(a - b) > 0.5f * contrast;
}

// The lattice grown from one seed: cells (i, j) in [-span, span]^2 holding candidate indices.
class Lattice {
 public:
  Lattice(int span) : span_(span), side_(2 * span + 1), cells_(side_ * side_, -1) {}
  int& at(int i, int j) { return cells_[(j + span_) * side_ + (i + span_)]; }
  int get(int i, int j) const {
    if (std::abs(i) > span_ || std::abs(j) > span_) return -1;
    return cells_[(j + span_) * side_ + (i + span_)];
  }
  bool inside(int i, int j) const { return std::abs(i) <= span_ && std::abs(j) <= span_; }

 private:
  int span_, side_;
  std::vector<int> cells_;
};

class GridBuilder {
 public:
  GridBuilder(std::vector<Candidate>* candidates, const cv::Mat& blurred, int cols, int rows)
      : cand_(*candidates), blurred_(blurred), cols_(cols), rows_(rows) {}

  // The lattice grown from seed (cells within `span` of it): false when the seed starts
  // no 2 x 2 block. *count cells are filled, within [imin, imax] x [jmin, jmax].
  bool grow_lattice(int seed, int span, Lattice* lattice_out, int* count_out, int* imin_out,
                    int* imax_out, int* jmin_out, int* jmax_out) {
    Lattice& lattice = *lattice_out;
    used_.assign(cand_.size(), 0);
    // A 2 x 2 block from the seed: its nearest X-junction neighbour, the nearest one more
    // than 30 deg off that line, and the corner that closes the parallelogram.
    const cv::Point2f s = cand_[seed].p;
    int a = -1, b = -1;
    float da = 1e30f, db = 1e30f;
    for (size_t k = 0; k < cand_.size(); ++k) {
      if (static_cast<int>(k) == seed) continue;
      const float d = cv::norm(cand_[k].p - s);
      if (d < 3 || d >= da) continue;
      if (!x_junction(k, 0.35f * d)) continue;
      da = d;
      a = static_cast<int>(k);
    }
    if (a < 0 || !x_junction(seed, 0.35f * da)) return false;
    const float contrast = contrast_around(blurred_, s, 0.35f * da);
    if (!along_edge(blurred_, s, cand_[a].p, contrast)) return false;
    const cv::Point2f u = cand_[a].p - s;
    for (size_t k = 0; k < cand_.size(); ++k) {
      if (static_cast<int>(k) == seed || static_cast<int>(k) == a) continue;
      const cv::Point2f w = cand_[k].p - s;
      const float d = cv::norm(w);
      if (d >= db || d > 3 * da) continue;
      const float sine = std::fabs(u.x * w.y - u.y * w.x) / (da * d);
      if (sine < 0.5f || !x_junction(k, 0.35f * std::min(d, da))) continue;
      if (!along_edge(blurred_, s, cand_[k].p, contrast)) continue;
      db = d;
      b = static_cast<int>(k);
    }
    if (b < 0) return false;
    const cv::Point2f v = cand_[b].p - s;
    const int c = nearest(s + u + v, kSnapShare * std::min(da, db), 0.35f * std::min(da, db));
    if (c < 0 || c == seed || c == a || c == b) return false;
    lattice.at(0, 0) = seed;
    lattice.at(1, 0) = a;
    lattice.at(0, 1) = b;
    lattice.at(1, 1) = c;
    used_[seed] = used_[a] = used_[b] = used_[c] = 1;
    int imin = 0, imax = 1, jmin = 0, jmax = 1, count = 4;
    // Grow by straight steps: a cell is predicted from each line of two filled cells that
    // leads to it (p1 + (p1 - p2)); every such prediction must agree with the candidate
    // taken, so a wrong snap in one direction cannot shear the lattice.
    const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (bool changed = true; changed;) {
      changed = false;
      for (int j = std::max(-span, jmin - 1); j <= std::min(span, jmax + 1); ++j)
        for (int i = std::max(-span, imin - 1); i <= std::min(span, imax + 1); ++i) {
          if (lattice.get(i, j) >= 0) continue;
          cv::Point2f sum(0, 0);
          std::array<cv::Point2f, 4> predicted;
          std::array<float, 4> spacing{};
          int n = 0;
          for (const auto& d : dirs) {
            const int n1 = lattice.get(i - d[0], j - d[1]),
                      n2 = lattice.get(i - 2 * d[0], j - 2 * d[1]);
            if (n1 < 0 || n2 < 0) continue;
            const cv::Point2f step = cand_[n1].p - cand_[n2].p;
            predicted[n] = cand_[n1].p + step;
            spacing[n] = cv::norm(step);
            sum += predicted[n];
            ++n;
          }
          if (n == 0) continue;
          const float min_spacing = *std::min_element(spacing.begin(), spacing.begin() + n);
          if (min_spacing < 3) continue;
          const int k = nearest(sum * (1.f / n), kSnapShare * min_spacing, 0.35f * min_spacing);
          if (k < 0) continue;
          bool agree = true;
          for (int m = 0; m < n; ++m)
            agree &= cv::norm(cand_[k].p - predicted[m]) < kSnapShare * spacing[m];
          if (!agree) continue;
          lattice.at(i, j) = k;
          used_[k] = 1;
          ++count;
          imin = std::min(imin, i), imax = std::max(imax, i);
          jmin = std::min(jmin, j), jmax = std::max(jmax, j);
          changed = true;
        }
    }
    *count_out = count;
    *imin_out = imin, *imax_out = imax, *jmin_out = jmin, *jmax_out = jmax;
    return true;
  }

  // The cols x rows grid (row-major, j * nx + i; nx, ny as found) grown from seed, or empty.
  bool grow(int seed, std::vector<cv::Point2f>* grid, int* nx, int* ny) {
    const int span = std::max(cols_, rows_) + 1;
    Lattice lattice(span);
    int count = 0, imin = 0, imax = 0, jmin = 0, jmax = 0;
    if (!grow_lattice(seed, span, &lattice, &count, &imin, &imax, &jmin, &jmax)) return false;
    if (count < cols_ * rows_) return false;
    // The board is the one complete cols x rows (or rows x cols) window of the lattice: a
    // few stray junctions past the board's edge (its frame, the background) may join the
    // lattice, but a second complete window means a bigger board than the one asked for.
    // Where several windows are complete, the stray junctions form whole rows: a board
    // held with a white margin inside a dark frame shows a junction at each of its edge
    // squares' outer corners (a black square, the margin, the frame); 8 of 13 views of
    // OpenCV's sample stereo pair do. The board is then the one window ringed by squares
    // (board_ring.h): outside a window that reaches into the margin lies the margin, one
    // tone. Two windows that both pass are a bigger board: not the one asked for.
    struct Window {
      int i0, j0, w, h;
    };
    std::vector<Window> complete;
    for (int orientation = 0; orientation < (cols_ == rows_ ? 1 : 2); ++orientation) {
      const int w = orientation == 0 ? cols_ : rows_, h = orientation == 0 ? rows_ : cols_;
      for (int j0 = jmin; j0 + h - 1 <= jmax; ++j0)
        for (int i0 = imin; i0 + w - 1 <= imax; ++i0) {
          bool full = true;
          for (int j = j0; j < j0 + h && full; ++j)
            for (int i = i0; i < i0 + w && full; ++i) full = lattice.get(i, j) >= 0;
          if (full) complete.push_back({i0, j0, w, h});
        }
    }
    if (complete.size() > 1)
      std::erase_if(complete, [&](const Window& c) {
        auto corner = [&](int i, int j) { return cand_[lattice.get(c.i0 + i, c.j0 + j)].p; };
        return !ringed_by_squares(ring_alternation(blurred_, corner, c.w, c.h, 1));
      });
    if (complete.size() != 1) return false;
    const int wi = complete[0].i0, wj = complete[0].j0, ww = complete[0].w, wh = complete[0].h;
    // A window whose squares go on past its edge is part of a bigger board whose lattice
    // did not grow whole (a junction missed): not the board asked for.
    auto window_corner = [&](int i, int j) { return cand_[lattice.get(wi + i, wj + j)].p; };
    if (board_goes_on(ring_alternation(blurred_, window_corner, ww, wh, 2))) return false;
    *nx = ww;
    *ny = wh;
    grid->assign(cols_ * rows_, cv::Point2f());
    for (int j = 0; j < wh; ++j)
      for (int i = 0; i < ww; ++i) (*grid)[j * ww + i] = cand_[lattice.get(wi + i, wj + j)].p;
    // Rows and columns bend smoothly under perspective and distortion: a step that
    // changes by more than two fifths of its length from one corner to the next is a
    // junction taken from elsewhere.
    for (int j = 0; j < wh; ++j)
      for (int i = 0; i < ww; ++i) {
        const cv::Point2f p = (*grid)[j * ww + i];
        if (i > 0 && i + 1 < ww) {
          const cv::Point2f a = (*grid)[j * ww + i - 1], b = (*grid)[j * ww + i + 1];
          if (cv::norm(a + b - 2 * p) > 0.2 * cv::norm(b - a)) return false;
        }
        if (j > 0 && j + 1 < wh) {
          const cv::Point2f a = (*grid)[(j - 1) * ww + i], b = (*grid)[(j + 1) * ww + i];
          if (cv::norm(a + b - 2 * p) > 0.2 * cv::norm(b - a)) return false;
        }
      }
    return true;
  }

 private:
  // The X-junction test of candidate k at about `radius` px (cached while the radius
  // stays within 25%).
  bool x_junction(size_t k, float radius) {
    radius = std::max(radius, 2.f);
    Candidate& c = cand_[k];
    if (c.checked_radius < 0 || std::fabs(c.checked_radius - radius) > 0.25f * radius) {
      c.x_junction = is_x_junction(blurred_, c.p, radius);
      c.checked_radius = radius;
    }
    return c.x_junction;
  }

  // The unused X-junction candidate nearest to p within max_distance px, or -1.
  int nearest(cv::Point2f p, float max_distance, float junction_radius) {
    int best = -1;
    float best_d = max_distance;
    for (size_t k = 0; k < cand_.size(); ++k) {
      if (used_[k]) continue;
      const float d = cv::norm(cand_[k].p - p);
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(k);
      }
    }
    if (best < 0 || !x_junction(best, junction_radius)) return -1;
    return best;
  }

  std::vector<Candidate>& cand_;
  std::vector<char> used_;
  const cv::Mat& blurred_;
  int cols_, rows_;
};

// The grid's (nx x ny, row-major) index of labelled corner (i, j) under symmetry g of
// the index rectangle: 0 identity, 1 half turn, 2 and 3 mirrors, 4-7 (square grids only)
// the transposes: quarter turns and diagonal mirrors.
int source_index(int g, int i, int j, int n_cols, int n_rows) {
  const int mi = n_cols - 1, mj = n_rows - 1;
  switch (g) {
    case 1:
      return (mj - j) * n_cols + (mi - i);
    case 2:
      return j * n_cols + (mi - i);
    case 3:
      return (mj - j) * n_cols + i;
    case 4:
      return i * n_cols + j;
    case 5:
      return (mi - i) * n_cols + (mj - j);
    case 6:
      return (mi - i) * n_cols + j;
    case 7:
      return i * n_cols + (mj - j);
    default:
      return j * n_cols + i;
  }
}

// Labels the found grid (nx x ny, nx * ny = cols * rows) as cols x rows in mrcal's order:
// never mirrored, i axis nearest the image's +x (saddle_corners.h).
std::vector<cv::Point2f> label(const std::vector<cv::Point2f>& grid, int nx, int ny, int cols,
                               int rows) {
  std::vector<cv::Point2f> g = grid;
  if (nx != cols) {  // found transposed: make the rows cols long
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) g[i * ny + j] = grid[j * nx + i];
  }
  std::vector<cv::Point2f> best, trial(g.size());
  double best_cos = -2;
  for (int s = 0; s < (cols == rows ? 8 : 4); ++s) {
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < cols; ++i) trial[j * cols + i] = g[source_index(s, i, j, cols, rows)];
    cv::Point2f ui(0, 0), uj(0, 0);
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i + 1 < cols; ++i) ui += trial[j * cols + i + 1] - trial[j * cols + i];
    for (int j = 0; j + 1 < rows; ++j)
      for (int i = 0; i < cols; ++i) uj += trial[(j + 1) * cols + i] - trial[j * cols + i];
    // Seen from the front, the board's +y is its +x turned by +90 deg in the image (y down).
    if (ui.x * uj.y - ui.y * uj.x <= 0) continue;
    const double c = ui.x / std::max(1e-9, std::hypot(double(ui.x), double(ui.y)));
    if (c > best_cos + 1e-9) {
      best_cos = c;
      best = trial;
    }
  }
  return best;
}

double min_spacing_px(const std::vector<cv::Point2f>& g, int cols, int rows) {
  double spacing = 1e30;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      if (i + 1 < cols)
        spacing = std::min<double>(spacing, cv::norm(g[j * cols + i + 1] - g[j * cols + i]));
      if (j + 1 < rows)
        spacing = std::min<double>(spacing, cv::norm(g[(j + 1) * cols + i] - g[j * cols + i]));
    }
  return spacing;
}

// The pyramid of an 8-bit image, full resolution first, down to the deepest level whose
// short side keeps kMinCoarseSidePx (at most kMaxLevel). Level L is a 2^L box average: its
// pixel x covers full-resolution pixels 2^L x .. 2^L x + 2^L - 1, whose centre is
// 2^L (x + 0.5) - 0.5.
std::vector<cv::Mat> pyramid(const cv::Mat& gray8) {
  int top = 0;
  while (top < kMaxLevel && (std::min(gray8.cols, gray8.rows) >> (top + 1)) >= kMinCoarseSidePx)
    ++top;
  std::vector<cv::Mat> levels = {gray8};
  for (int l = 1; l <= top; ++l) {
    cv::Mat next;
    cv::resize(levels.back(), next, cv::Size(levels.back().cols / 2, levels.back().rows / 2), 0, 0,
               cv::INTER_AREA);
    levels.push_back(next);
  }
  return levels;
}

// One pyramid level: the coarse grid (coarse-level px) or empty.
std::vector<cv::Point2f> find_at_level(const cv::Mat& level8, int cols, int rows) {
  const Response r = saddle_response(level8);
  const int n = cols * rows;
  std::vector<Candidate> candidates = find_candidates(r.saddle, n, 4 * n + 200);
  if (static_cast<int>(candidates.size()) < n) return {};
  GridBuilder builder(&candidates, r.blurred, cols, rows);
  std::vector<cv::Point2f> grid;
  int nx = 0, ny = 0;
  // Seeds: the strongest candidates; a seed off the board grows no full grid.
  const int seeds = std::min<int>(12, candidates.size());
  for (int s = 0; s < seeds; ++s)
    if (builder.grow(s, &grid, &nx, &ny)) return label(grid, nx, ny, cols, rows);
  return {};
}

// Where a corner should be from its grid neighbours: the mean of the midpoints of its
// row and column neighbours, or a straight step from the two next ones at the grid's
// border. Off by a fraction of a pixel under perspective and distortion, where a slid
// corner is off by pixels.
cv::Point2f predicted_from_neighbours(const std::vector<cv::Point2f>& g, int cols, int rows, int i,
                                      int j) {
  auto at = [&](int a, int b) { return g[static_cast<size_t>(b * cols + a)]; };
  cv::Point2f sum(0, 0);
  int n = 0;
  auto along = [&](int di, int dj) {
    const int a1 = i - di, b1 = j - dj, a2 = i + di, b2 = j + dj;
    auto inside = [&](int a, int b) { return a >= 0 && a < cols && b >= 0 && b < rows; };
    if (inside(a1, b1) && inside(a2, b2)) {
      sum += 0.5f * (at(a1, b1) + at(a2, b2));
      ++n;
    } else if (inside(a1, b1) && inside(a1 - di, b1 - dj)) {
      sum += 2.f * at(a1, b1) - at(a1 - di, b1 - dj);
      ++n;
    } else if (inside(a2, b2) && inside(a2 + di, b2 + dj)) {
      sum += 2.f * at(a2, b2) - at(a2 + di, b2 + dj);
      ++n;
    }
  };
  along(1, 0);
  along(0, 1);
  return n > 0 ? sum / static_cast<float>(n) : at(i, j);
}

// The refined corners checked on the image. cornerSubPix's criterion (the gradient
// orthogonal to the offset from the corner) holds anywhere along a straight edge, so a
// window that sees mostly one edge can carry a corner along it: 9.9 px in view 23 of the
// README's example set. A refined corner must still be an X-junction on a small circle
// around it (an eighth of its spacing, 2.5-4 px); one that is not is refined again from its
// neighbours' prediction with a smaller window, and if that fails too it is left out (weight 0:
// missing, as mrcal takes it) rather than handed on pixels off.
void recheck_corners(const cv::Mat& gray8, int cols, int rows, std::vector<cv::Point2f>* corners,
                     std::vector<double>* weights) {
  cv::Mat blurred;
  gray8.convertTo(blurred, CV_32F, 1.0 / 255);
  cv::GaussianBlur(blurred, blurred, cv::Size(), 1.0);
  cv::Mat gray;  // cornerSubPix's input, as refine_corners_subpix gives it
  std::vector<cv::Point2f>& g = *corners;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      const size_t k = static_cast<size_t>(j * cols + i);
      float spacing_px = 1e9f;
      for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int a = i + di, b = j + dj;
        if (a >= 0 && a < cols && b >= 0 && b < rows)
          spacing_px = std::min(spacing_px, static_cast<float>(cv::norm(g[k] - g[b * cols + a])));
      }
      // Small, so that a corner carried more than a few pixels along an edge has the
      // junction outside its circle (two sectors, not four).
      const float radius_px = std::clamp(0.12f * spacing_px, 2.5f, 4.f);
      if (is_x_junction(blurred, g[k], radius_px)) continue;
      if (gray.empty()) gray8.convertTo(gray, CV_32F);
      const cv::Point2f predicted = predicted_from_neighbours(g, cols, rows, i, j);
      std::vector<cv::Point2f> again = {predicted};
      const int half_window = std::clamp(static_cast<int>(0.2f * spacing_px), 2, 4);
      cv::cornerSubPix(
          gray, again, cv::Size(half_window, half_window), cv::Size(-1, -1),
          cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
      const bool placed = std::isfinite(again[0].x) && std::isfinite(again[0].y) &&
                          cv::norm(again[0] - predicted) < 0.25 * spacing_px &&
                          is_x_junction(blurred, again[0], radius_px);
      if (placed) {
        g[k] = again[0];
      } else {
        g[k] = predicted;
        (*weights)[k] = 0;
      }
    }
  }
}

}  // namespace

Result<ChessboardCorners> find_chessboard_corners_saddle(const cv::Mat& image, int cols, int rows) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image",
                      "chessboard detection needs a single-channel 8- or 16-bit image");
  if (cols < 2 || rows < 2)
    return make_error("invalid_argument", "a chessboard needs at least 2 x 2 inner corners");
  const cv::Mat gray8 = stretch_to_8bit(image);
  const std::vector<cv::Mat> levels = pyramid(gray8);
  const int top = static_cast<int>(levels.size()) - 1;
  for (int l = top; l >= 0; --l) {
    std::vector<cv::Point2f> corners = find_at_level(levels[l], cols, rows);
    if (corners.empty()) continue;
    // The coarse level's corners are refined there first (a corner's position within a
    // fraction of that level's pixel), then at full resolution.
    // A candidate is a local maximum within a third of a spacing of its grid's
    // prediction, and may sit a pixel or two off the junction where the board's corner is
    // weak (at the imager's edges): the first refinement may move it by up to a quarter
    // of the spacing, never onto a neighbour.
    const double first_move_px = std::max(1.5, 0.25 * min_spacing_px(corners, cols, rows));
    if (l > 0) {
      refine_corners_subpix(levels[l], cols, rows, &corners, first_move_px);
      const float scale = static_cast<float>(1 << l);
      for (auto& p : corners) p = (p + cv::Point2f(0.5f, 0.5f)) * scale - cv::Point2f(0.5f, 0.5f);
    }
    refine_corners_subpix(image, cols, rows, &corners, first_move_px, kRefineWindowShare);
    ChessboardCorners out;
    out.cols = cols;
    out.rows = rows;
    out.detector = "saddle";
    out.weights.assign(corners.size(), 1.0);
    recheck_corners(gray8, cols, rows, &corners, &out.weights);
    for (const auto& p : corners) out.corners_px.emplace_back(p.x, p.y);
    return out;
  }
  return make_error("board_not_found", "no complete " + std::to_string(cols) + "x" +
                                           std::to_string(rows) +
                                           " inner-corner chessboard found in the image");
}

Result<SaddleLattice> find_saddle_lattice(const cv::Mat& image, int max_span, int min_corners) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image",
                      "chessboard detection needs a single-channel 8- or 16-bit image");
  if (max_span < 2 || min_corners < 4)
    return make_error("invalid_argument", "a lattice needs a span of 2 and 4 corners or more");
  const std::vector<cv::Mat> levels = pyramid(stretch_to_8bit(image));
  const int top = static_cast<int>(levels.size()) - 1;
  for (int l = top; l >= 0; --l) {
    const Response r = saddle_response(levels[l]);
    const int n = (max_span - 1) * (max_span - 1);
    std::vector<Candidate> candidates = find_candidates(r.saddle, n, 4 * n + 200);
    if (static_cast<int>(candidates.size()) < min_corners) continue;
    GridBuilder builder(&candidates, r.blurred, max_span, max_span);
    Lattice lattice(max_span), best(max_span);
    int best_count = 0;
    const int seeds = std::min<int>(12, candidates.size());
    for (int s = 0; s < seeds; ++s) {
      int count = 0, imin, imax, jmin, jmax;
      lattice = Lattice(max_span);
      if (!builder.grow_lattice(s, max_span, &lattice, &count, &imin, &imax, &jmin, &jmax))
        continue;
      if (count > best_count) {
        best_count = count;
        best = lattice;
      }
    }
    if (best_count < min_corners) continue;
    SaddleLattice out;
    out.level = l;
    const float scale = static_cast<float>(1 << l);
    for (int j = -max_span; j <= max_span; ++j)
      for (int i = -max_span; i <= max_span; ++i) {
        const int k = best.get(i, j);
        if (k < 0) continue;
        const cv::Point2f p =
            (candidates[k].p + cv::Point2f(0.5f, 0.5f)) * scale - cv::Point2f(0.5f, 0.5f);
        out.ij.emplace_back(i, j);
        out.corners_px.emplace_back(p.x, p.y);
      }
    return out;
  }
  return make_error("board_not_found", "no lattice of " + std::to_string(min_corners) +
                                           " chessboard corners found in the image");
}

}  // namespace camlab::calib
