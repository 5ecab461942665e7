#include "analysis/lightfield/microlens_lattice.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace camlab::analysis::lightfield {

namespace {

using Vec = std::array<double, 2>;

// Centres refined and fitted at most (spread over the image by a stride).
constexpr size_t kMaxCentres = 600;

double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1]; }
double norm(const Vec& a) { return std::hypot(a[0], a[1]); }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The spacing (px) of the white image's rows of microlens images: 1 / the frequency of
// its spectrum's lowest strong peak away from zero (a central crop, Hann-windowed). The
// lowest, not the strongest: microlens images that nearly tile the sensor leave a white
// of bright plateaus between dark gaps, and the gaps' own lattice (finer) can outshine
// the images' fundamental.
double lattice_spacing_px(const cv::Mat& w) {
  const int n = std::min({w.rows, w.cols, 256});
  cv::Mat crop = w(cv::Rect((w.cols - n) / 2, (w.rows - n) / 2, n, n)).clone();
  crop -= cv::mean(crop)[0];
  cv::Mat hann;
  cv::createHanningWindow(hann, crop.size(), CV_32F);
  crop = crop.mul(hann);
  cv::Mat spectrum;
  cv::dft(crop, spectrum, cv::DFT_COMPLEX_OUTPUT);
  cv::Mat magnitude(n, n, CV_64F, cv::Scalar(0));
  double strongest = 0;
  const auto radius_of = [n](int u, int v) {
    return std::hypot(u <= n / 2 ? u : u - n, v <= n / 2 ? v : v - n);
  };
  for (int v = 0; v < n; ++v)
    for (int u = 0; u < n; ++u) {
      const double radius = radius_of(u, v);
      // Not the window's leakage around zero, not beyond 2 px per period.
      if (radius < 3 || radius > n / 2.0) continue;
      const cv::Vec2f c = spectrum.at<cv::Vec2f>(v, u);
      magnitude.at<double>(v, u) = std::hypot(c[0], c[1]);
      strongest = std::max(strongest, magnitude.at<double>(v, u));
    }
  double lowest = 0;
  for (int v = 0; v < n; ++v)
    for (int u = 0; u < n; ++u) {
      const double m = magnitude.at<double>(v, u);
      if (m < 0.25 * strongest) continue;
      bool peak = true;  // a local maximum of the spectrum (wrapping around)
      for (int dv = -1; dv <= 1 && peak; ++dv)
        for (int du = -1; du <= 1; ++du)
          if ((du || dv) && magnitude.at<double>((v + dv + n) % n, (u + du + n) % n) > m) {
            peak = false;
            break;
          }
      const double radius = radius_of(u, v);
      if (peak && (lowest == 0 || radius < lowest)) lowest = radius;
    }
  return lowest > 0 ? n / lowest : 0;
}

// Bilinear interpolation (pixel centres at integers; the caller keeps inside).
double bilinear(const cv::Mat& w, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double a = x - x0, b = y - y0;
  const float* r0 = w.ptr<float>(y0) + x0;
  const float* r1 = w.ptr<float>(y0 + 1) + x0;
  return (1 - b) * ((1 - a) * r0[0] + a * r0[1]) + b * ((1 - a) * r1[0] + a * r1[1]);
}

// How far the white is from central symmetry about c: the sum over offsets d in a disk
// of radius `radius` of (w(c + d) - w(c - d))^2.
double asymmetry(const cv::Mat& w, const Vec& c, double radius) {
  const int r = static_cast<int>(std::ceil(radius));
  double sum = 0;
  for (int dy = 0; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      if (dy == 0 && dx <= 0) continue;  // each pair once
      if (dx * dx + dy * dy > radius * radius) continue;
      const double d = bilinear(w, c[0] + dx, c[1] + dy) - bilinear(w, c[0] - dx, c[1] - dy);
      sum += d * d;
    }
  return sum;
}

// The centre of the microlens image near (x, y): the point about which the white is
// most nearly centrally symmetric over the image (a disk of half a spacing), by grid
// searches of shrinking steps. A microlens image is centrally symmetric about its centre
// whether its top is flat or not, and at a centre on a pixel centre or corner the pairs
// meet exactly. False when the search would leave the image.
bool symmetric_centre(const cv::Mat& w, int x, int y, double spacing, Vec* c) {
  const double radius = 0.5 * spacing, reach = 0.3 * spacing;
  const double margin = radius + reach + 2;
  if (x - margin < 0 || y - margin < 0 || x + margin >= w.cols - 1 || y + margin >= w.rows - 1)
    return false;
  *c = {static_cast<double>(x), static_cast<double>(y)};
  double step = 0.5, span = reach;
  while (step > 0.002) {
    Vec best = *c;
    double least = asymmetry(w, *c, radius);
    const int n = static_cast<int>(std::ceil(span / step));
    const Vec around = *c;
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        const Vec p = {around[0] + i * step, around[1] + j * step};
        const double a = asymmetry(w, p, radius);
        if (a < least) least = a, best = p;
      }
    *c = best;
    span = step;
    step /= 5;
  }
  return true;
}

}  // namespace

double MicrolensLattice::pitch_px() const { return norm(e1_px); }

double MicrolensLattice::row_pitch() const {
  const double p = pitch_px();
  const Vec normal = {-e1_px[1] / p, e1_px[0] / p};
  return 0.5 * std::fabs(dot(pair_px, normal)) / p;
}

double MicrolensLattice::odd_row_shift() const {
  const double p = pitch_px();
  const Vec along = {e1_px[0] / p, e1_px[1] / p};
  return (dot(e2_px, along) - 0.5 * dot(pair_px, along)) / p;
}

std::array<double, 2> MicrolensLattice::centre(int k, int l) const {
  const int pairs = l >= 0 ? l / 2 : -((1 - l) / 2);  // floor(l / 2)
  const int odd = l - 2 * pairs;
  return {origin_px[0] + k * e1_px[0] + pairs * pair_px[0] + odd * e2_px[0],
          origin_px[1] + k * e1_px[1] + pairs * pair_px[1] + odd * e2_px[1]};
}

nlohmann::json to_json(const MicrolensLattice& m) {
  return {{"layout", m.staggered ? "hex" : "square"},
          {"pitch_px", m.pitch_px()},
          {"origin_px", m.origin_px},
          {"e1_px", m.e1_px},
          {"e2_px", m.e2_px},
          {"pair_px", m.pair_px},
          {"columns", m.columns},
          {"rows", m.rows},
          {"centres_found", m.centres_found},
          {"fit_rms_px", m.fit_rms_px}};
}

Result<MicrolensLattice> find_microlens_lattice(const cv::Mat& white, int black_level_dn) {
  cv::Mat w;
  white.convertTo(w, CV_32F, 1.0, -black_level_dn);
  w = cv::max(w, 0.0);
  double brightest = 0;
  cv::minMaxLoc(w, nullptr, &brightest);
  if (!(brightest > 0))
    return make_error("no_signal", "the white image holds no light above black level " +
                                       std::to_string(black_level_dn) + " DN");
  cv::Scalar mean, deviation;
  cv::meanStdDev(w, mean, deviation);
  const double spacing = deviation[0] > 0.01 * mean[0] ? lattice_spacing_px(w) : 0.0;
  if (!(spacing >= 2))
    return make_error("no_contrast", "the white image shows no lattice of microlens images");

  // Candidates: maxima of the white smoothed at a quarter spacing.
  cv::Mat smooth, grown;
  cv::GaussianBlur(w, smooth, cv::Size(), spacing / 4, spacing / 4, cv::BORDER_REFLECT);
  const int r = std::max(1, static_cast<int>(std::lround(0.35 * spacing)));
  cv::dilate(smooth, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  double smooth_max = 0;
  cv::minMaxLoc(smooth, nullptr, &smooth_max);
  // Only where the smoothing saw whole neighbourhoods: nearer the border it sees the
  // border's reflection (the lattice still covers those images).
  const int inner = static_cast<int>(std::ceil(1.25 * spacing));
  std::vector<std::array<int, 2>> maxima;
  for (int y = inner; y < w.rows - inner; ++y)
    for (int x = inner; x < w.cols - inner; ++x) {
      const float s = smooth.at<float>(y, x);
      if (s < 0.5 * smooth_max || s < grown.at<float>(y, x)) continue;
      // Tied maxima (a centre between pixels): the first of them.
      bool seen = false;
      for (auto it = maxima.rbegin(); it != maxima.rend() && !seen; ++it) {
        if ((*it)[1] < y - spacing) break;
        seen = std::hypot((*it)[0] - x, (*it)[1] - y) < 0.3 * spacing;
      }
      if (!seen) maxima.push_back({x, y});
    }
  if (maxima.size() < 4)
    return make_error("too_few_samples", "found " + std::to_string(maxima.size()) +
                                             " whole microlens images in the white image; "
                                             "at least 4 are needed to fit the lattice");

  // The basis from the maxima's neighbour vectors (whole pixels, but medians over many),
  // through buckets of one spacing.
  std::map<std::pair<int, int>, std::vector<size_t>> buckets;
  const auto bucket_of = [&](const std::array<int, 2>& c) {
    return std::pair<int, int>{static_cast<int>(std::floor(c[0] / spacing)),
                               static_cast<int>(std::floor(c[1] / spacing))};
  };
  for (size_t i = 0; i < maxima.size(); ++i) buckets[bucket_of(maxima[i])].push_back(i);
  std::vector<Vec> neighbours;
  for (const auto& c : maxima) {
    const auto [bx, by] = bucket_of(c);
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        auto it = buckets.find({bx + dx, by + dy});
        if (it == buckets.end()) continue;
        for (size_t j : it->second) {
          const Vec v = {static_cast<double>(maxima[j][0] - c[0]),
                         static_cast<double>(maxima[j][1] - c[1])};
          const double length = norm(v);
          if (length > 0.5 * spacing && length < 1.6 * spacing) neighbours.push_back(v);
        }
      }
  }
  // e1: along +x (within 30 degrees), the nearest such.
  std::vector<double> ex, ey;
  double shortest = 1e300;
  for (const Vec& v : neighbours)
    if (v[0] > 0 && std::fabs(v[1]) < 0.58 * v[0]) shortest = std::min(shortest, norm(v));
  for (const Vec& v : neighbours)
    if (v[0] > 0 && std::fabs(v[1]) < 0.58 * v[0] && norm(v) < 1.2 * shortest) {
      ex.push_back(v[0]);
      ey.push_back(v[1]);
    }
  if (ex.empty()) return make_error("no_contrast", "the microlens images found form no rows");
  MicrolensLattice lattice;
  lattice.e1_px = {median(ex), median(ey)};
  const double pitch = norm(lattice.e1_px);
  const Vec along = {lattice.e1_px[0] / pitch, lattice.e1_px[1] / pitch};
  const Vec across = {-along[1], along[0]};  // +y
  // e2: the nearest neighbour in the next row; straight below (square) or half a pitch
  // to the right of it (staggered).
  std::vector<Vec> below;
  double nearest_row = 1e300;
  for (const Vec& v : neighbours)
    if (dot(v, across) > 0.4 * pitch) nearest_row = std::min(nearest_row, dot(v, across));
  for (const Vec& v : neighbours)
    if (dot(v, across) > 0.4 * pitch && dot(v, across) < 1.2 * nearest_row) below.push_back(v);
  std::vector<double> straight_x, straight_y, right_x, right_y;
  for (const Vec& v : below) {
    const double a = dot(v, along) / pitch;
    if (std::fabs(a) < 0.25) {
      straight_x.push_back(v[0]);
      straight_y.push_back(v[1]);
    } else if (a > 0.25 && a < 0.75) {
      right_x.push_back(v[0]);
      right_y.push_back(v[1]);
    }
  }
  lattice.staggered = right_x.size() > straight_x.size();
  const Vec e2 = lattice.staggered ? Vec{median(right_x), median(right_y)}
                                   : Vec{median(straight_x), median(straight_y)};
  if (!(dot(e2, across) > 0))
    return make_error("no_contrast", "the microlens images found form no second row");

  // The centres, refined: a few thousand spread over the image are plenty for a lattice.
  const size_t stride = std::max<size_t>(1, maxima.size() / kMaxCentres);
  std::vector<Vec> centres;
  for (size_t i = 0; i < maxima.size(); i += stride) {
    Vec c;
    if (symmetric_centre(w, maxima[i][0], maxima[i][1], spacing, &c)) centres.push_back(c);
  }
  if (centres.size() < 4)
    return make_error("too_few_samples", "refined " + std::to_string(centres.size()) +
                                             " microlens centres; at least 4 are needed to fit "
                                             "the lattice");
  // Indices in the basis (e1, e2) from the centre nearest the image's middle, then the
  // least-squares lattice: c = o + k e1 + m e2, for x and y on their own.
  const Vec middle = {w.cols / 2.0, w.rows / 2.0};
  const Vec ref =
      *std::min_element(centres.begin(), centres.end(), [&](const Vec& a, const Vec& b) {
        return norm({a[0] - middle[0], a[1] - middle[1]}) <
               norm({b[0] - middle[0], b[1] - middle[1]});
      });
  const double det = lattice.e1_px[0] * e2[1] - lattice.e1_px[1] * e2[0];
  cv::Mat A(static_cast<int>(centres.size()), 3, CV_64F), bx(A.rows, 1, CV_64F),
      by(A.rows, 1, CV_64F);
  std::vector<std::array<int, 2>> index(centres.size());
  for (size_t i = 0; i < centres.size(); ++i) {
    const Vec d = {centres[i][0] - ref[0], centres[i][1] - ref[1]};
    const double k = (d[0] * e2[1] - d[1] * e2[0]) / det;
    const double m = (lattice.e1_px[0] * d[1] - lattice.e1_px[1] * d[0]) / det;
    index[i] = {static_cast<int>(std::lround(k)), static_cast<int>(std::lround(m))};
    const int row = static_cast<int>(i);
    A.at<double>(row, 0) = 1;
    A.at<double>(row, 1) = index[i][0];
    A.at<double>(row, 2) = index[i][1];
    bx.at<double>(row) = centres[i][0];
    by.at<double>(row) = centres[i][1];
  }
  cv::Mat sx, sy;
  cv::solve(A, bx, sx, cv::DECOMP_SVD);
  cv::solve(A, by, sy, cv::DECOMP_SVD);
  const Vec o = {sx.at<double>(0), sy.at<double>(0)};
  lattice.e1_px = {sx.at<double>(1), sy.at<double>(1)};
  const Vec fitted_e2 = {sx.at<double>(2), sy.at<double>(2)};
  double squares = 0;
  for (size_t i = 0; i < centres.size(); ++i) {
    const double px = o[0] + index[i][0] * lattice.e1_px[0] + index[i][1] * fitted_e2[0];
    const double py = o[1] + index[i][0] * lattice.e1_px[1] + index[i][1] * fitted_e2[1];
    squares +=
        (px - centres[i][0]) * (px - centres[i][0]) + (py - centres[i][1]) * (py - centres[i][1]);
  }
  lattice.centres_found = static_cast<int>(centres.size());
  lattice.fit_rms_px = std::sqrt(squares / static_cast<double>(centres.size()));

  // Rows of microlenses (row l = m, column k + floor(m/2) for a staggered lattice), and
  // the rectangle of them whose whole images lie in the raw image.
  lattice.e2_px = fitted_e2;
  lattice.pair_px = {2 * fitted_e2[0] - (lattice.staggered ? lattice.e1_px[0] : 0),
                     2 * fitted_e2[1] - (lattice.staggered ? lattice.e1_px[1] : 0)};
  lattice.origin_px = o;
  // A microlens is there when its image lies inside the raw image and its centre is lit
  // as the others' are (the lattice extends into dark margins where there is none).
  std::vector<double> centre_white;
  for (const Vec& c : centres) centre_white.push_back(bilinear(w, c[0], c[1]));
  const double lit = 0.5 * median(centre_white);
  const double half = (norm(lattice.e1_px) - 1) / 2;  // outermost pixel centres of an image
  const auto inside = [&](int k, int l) {
    const Vec c = lattice.centre(k, l);
    return c[0] - half >= -1e-6 && c[1] - half >= -1e-6 && c[0] + half <= w.cols - 1 + 1e-6 &&
           c[1] + half <= w.rows - 1 + 1e-6 && bilinear(w, c[0], c[1]) >= lit;
  };
  // Each row's microlenses: the interval of k whose centres keep `half` inside the image
  // (linear in k), then trimmed at its ends to lit ones.
  const double row_step = std::max(1.0, std::fabs(dot(lattice.pair_px, across)) / 2);
  const int reach_l = static_cast<int>(std::max(w.cols, w.rows) / row_step) + 4;
  struct Row {
    int l, a, b;  // the row's microlenses k = a .. b
  };
  std::vector<Row> rows;
  for (int l = -reach_l; l <= reach_l; ++l) {
    const Vec base = lattice.centre(0, l);
    double lo = -1e9, hi = 1e9;
    for (int axis = 0; axis < 2; ++axis) {
      const double step = lattice.e1_px[static_cast<size_t>(axis)];
      const double min_c = half, max_c = (axis == 0 ? w.cols : w.rows) - 1 - half;
      const double from = base[static_cast<size_t>(axis)];
      if (std::fabs(step) < 1e-12) {
        if (from < min_c - 1e-6 || from > max_c + 1e-6) lo = 1, hi = 0;
        continue;
      }
      const double k_a = (min_c - from) / step, k_b = (max_c - from) / step;
      lo = std::max(lo, std::min(k_a, k_b));
      hi = std::min(hi, std::max(k_a, k_b));
    }
    int a = static_cast<int>(std::ceil(lo - 1e-6)), b = static_cast<int>(std::floor(hi + 1e-6));
    while (a <= b && !inside(a, l)) ++a;
    while (a <= b && !inside(b, l)) --b;
    if (a <= b) rows.push_back({l, a, b});
  }
  if (rows.empty())
    return make_error("too_few_samples", "no whole microlens image lies in the raw image");
  // The rectangle of microlenses: rows l0 .. l1, and in every row the same count. Which
  // of a staggered lattice's rows are the shifted ones is a choice: re-index the rows an
  // odd number from the first by s = -1, 0 or 1 to keep the most columns.
  const int l0 = rows.front().l, l1 = rows.back().l;
  int best_s = 0, k0 = 0, k1 = -1;
  for (int s = -1; s <= 1; ++s) {
    int lo = -(1 << 30), hi = 1 << 30;
    for (const Row& r : rows) {
      const int shift = (r.l - l0) % 2 != 0 ? s : 0;
      lo = std::max(lo, r.a - shift);
      hi = std::min(hi, r.b - shift);
    }
    if (hi - lo > k1 - k0) best_s = s, k0 = lo, k1 = hi;
  }
  if (k1 < k0 || static_cast<int>(rows.size()) != l1 - l0 + 1)
    return make_error("too_few_samples", "no rectangle of whole microlens images in the raw image");
  const Vec first = lattice.centre(k0, l0);
  if (l1 > l0) {
    const Vec next = lattice.centre(k0 + best_s, l0 + 1);
    lattice.e2_px = {next[0] - first[0], next[1] - first[1]};
  }
  lattice.origin_px = first;
  lattice.columns = k1 - k0 + 1;
  lattice.rows = l1 - l0 + 1;
  return lattice;
}

}  // namespace camlab::analysis::lightfield
