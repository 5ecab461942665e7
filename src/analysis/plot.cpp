// Axis scaling and drawing for write_plot().
#include "analysis/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace camlab::analysis {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string tick_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

cv::Scalar colour_of(int bgr) { return cv::Scalar((bgr >> 16) & 255, (bgr >> 8) & 255, bgr & 255); }

struct Range {
  double lo = kInf, hi = -kInf;
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool ok() const { return hi >= lo; }
};

// The heat map's value at data point (x, y): bilinear between the grid's nodes, NaN when
// a node it needs has no value or the point lies outside the grid.
double heat_at(const PlotHeatmap& h, double x, double y) {
  const double gx = (x - h.x0) / (h.x1 - h.x0) * (h.cols - 1);
  const double gy = (y - h.y0) / (h.y1 - h.y0) * (h.rows - 1);
  if (!(gx >= 0 && gy >= 0 && gx <= h.cols - 1 && gy <= h.rows - 1)) return std::nan("");
  const int i = std::min(static_cast<int>(gx), h.cols - 2),
            j = std::min(static_cast<int>(gy), h.rows - 2);
  const double fx = gx - i, fy = gy - j;
  auto v = [&](int a, int b) { return h.values[static_cast<size_t>(b) * h.cols + a]; };
  return (1 - fy) * ((1 - fx) * v(i, j) + fx * v(i + 1, j)) +
         fy * ((1 - fx) * v(i, j + 1) + fx * v(i + 1, j + 1));
}

}  // namespace

Status write_plot(const std::filesystem::path& png_path, const PlotSpec& spec) {
  auto tx = [&](double v) { return spec.log_x ? std::log10(v) : v; };
  auto ty = [&](double v) { return spec.log_y ? std::log10(v) : v; };
  auto drawable = [&](double x, double y) {
    return std::isfinite(x) && std::isfinite(y) && (!spec.log_x || x > 0) && (!spec.log_y || y > 0);
  };
  const PlotHeatmap* heat =
      spec.heatmap && spec.heatmap->cols >= 2 && spec.heatmap->rows >= 2 &&
              spec.heatmap->values.size() ==
                  static_cast<size_t>(spec.heatmap->cols) * spec.heatmap->rows &&
              spec.heatmap->x1 != spec.heatmap->x0 && spec.heatmap->y1 != spec.heatmap->y0
          ? &*spec.heatmap
          : nullptr;
  Range rx, ry;  // in axis units (log10 on log axes)
  for (const PlotSeries& s : spec.series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!drawable(s.x[i], s.y[i])) continue;
      const double e = i < s.y_error.size() && std::isfinite(s.y_error[i]) ? s.y_error[i] : 0.0;
      rx.add(tx(s.x[i] - 0.5 * s.bar_width));
      rx.add(tx(s.x[i] + 0.5 * s.bar_width));
      ry.add(spec.log_y ? ty(s.y[i]) : s.y[i] - e);
      ry.add(spec.log_y ? ty(s.y[i]) : s.y[i] + e);
      if (s.bar_width > 0 && !spec.log_y) ry.add(0.0);
      if (i < s.dx.size() && i < s.dy.size() && drawable(s.x[i] + s.dx[i], s.y[i] + s.dy[i])) {
        rx.add(tx(s.x[i] + s.dx[i]));
        ry.add(ty(s.y[i] + s.dy[i]));
      }
    }
  if (heat) {
    rx.add(tx(heat->x0));
    rx.add(tx(heat->x1));
    ry.add(ty(heat->y0));
    ry.add(ty(heat->y1));
  }
  if (!rx.ok() || !ry.ok()) return make_error("empty_plot", "nothing to plot in " + spec.title);
  double x0 = rx.lo, x1 = rx.hi, y0 = ry.lo, y1 = ry.hi;
  if (x1 - x0 < 1e-12) {
    x0 -= 0.5;
    x1 += 0.5;
  }
  if (y1 - y0 < 1e-12) {
    y0 -= 0.5;
    y1 += 0.5;
  }
  double mx = 0.05 * (x1 - x0), my = 0.08 * (y1 - y0);
  if (spec.x_range) {
    x0 = tx(spec.x_range->first);
    x1 = tx(spec.x_range->second);
    mx = 0;
  }
  if (spec.y_range) {
    y0 = ty(spec.y_range->first);
    y1 = ty(spec.y_range->second);
    my = 0;
  }
  x0 -= mx;
  x1 += mx;
  y0 -= my;
  y1 += my;

  int width = std::clamp(spec.width_px, 200, 4000), height = std::clamp(spec.height_px, 150, 4000);
  const int left = 70, right = heat ? 95 : 20, top = 40, bottom = 50;
  int pw = width - left - right, ph = height - top - bottom;
  if (spec.equal_aspect) {
    // The axis with more pixels per unit gives some up: the canvas shrinks to the data.
    const double scale = std::min(pw / (x1 - x0), ph / (y1 - y0));
    pw = std::max(50, static_cast<int>(scale * (x1 - x0)));
    ph = std::max(50, static_cast<int>(scale * (y1 - y0)));
    width = left + pw + right;
    height = top + ph + bottom;
  }
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto col_of = [&](double xt) { return left + (xt - x0) / (x1 - x0) * pw; };
  auto row_of = [&](double yt) {
    const double f = (yt - y0) / (y1 - y0);
    return spec.y_down ? top + f * ph : top + ph - f * ph;
  };
  auto px = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(col_of(tx(x)))),
                     static_cast<int>(std::lround(row_of(ty(y)))));
  };
  const cv::Scalar black(0, 0, 0), grey(200, 200, 200);

  if (heat) {
    // Colours in `level` units: the value, or its log10.
    auto level_of = [&](double v) {
      return heat->log_scale ? (v > 0 ? std::log10(v) : std::nan("")) : v;
    };
    auto value_of = [&](double l) { return heat->log_scale ? std::pow(10.0, l) : l; };
    Range vr;
    for (double v : heat->values) vr.add(level_of(v));
    if (heat->range) vr = {level_of(heat->range->first), level_of(heat->range->second)};
    if (vr.ok()) {
      const double span = vr.hi > vr.lo ? vr.hi - vr.lo : 1.0;
      cv::Mat level(ph, pw, CV_8U, cv::Scalar(0)), valid(ph, pw, CV_8U, cv::Scalar(0));
      for (int r = 0; r < ph; ++r)
        for (int c = 0; c < pw; ++c) {
          const double xt = x0 + (c + 0.5) / pw * (x1 - x0);
          const double f = (r + 0.5) / ph;
          const double yt = spec.y_down ? y0 + f * (y1 - y0) : y1 - f * (y1 - y0);
          const double v = level_of(heat_at(*heat, spec.log_x ? std::pow(10.0, xt) : xt,
                                            spec.log_y ? std::pow(10.0, yt) : yt));
          if (!std::isfinite(v)) continue;
          level.at<uint8_t>(r, c) =
              static_cast<uint8_t>(std::clamp((v - vr.lo) / span, 0.0, 1.0) * 255);
          valid.at<uint8_t>(r, c) = 255;
        }
      cv::Mat coloured;
      cv::applyColorMap(level, coloured, cv::COLORMAP_VIRIDIS);
      coloured.copyTo(img(cv::Rect(left, top, pw, ph)), valid);
      // Colour bar with its range.
      cv::Mat bar(ph, 16, CV_8U);
      for (int r = 0; r < ph; ++r) bar.row(r).setTo(255 - r * 255 / std::max(1, ph - 1));
      cv::Mat bar_c;
      cv::applyColorMap(bar, bar_c, cv::COLORMAP_VIRIDIS);
      bar_c.copyTo(img(cv::Rect(width - right + 10, top, 16, ph)));
      for (int k = 0; k <= 4; ++k)
        cv::putText(img, tick_text(value_of(vr.hi - k * (vr.hi - vr.lo) / 4)),
                    cv::Point(width - right + 30, top + 4 + k * ph / 4), cv::FONT_HERSHEY_SIMPLEX,
                    0.38, black, 1, cv::LINE_AA);
      cv::putText(img, heat->label, cv::Point(width - right - 10, top - 8),
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
    }
  }

  cv::rectangle(img, cv::Point(left, top), cv::Point(left + pw, top + ph), black, 1);
  for (int k = 0; k <= 4; ++k) {
    const double xt = x0 + mx + k * (x1 - x0 - 2 * mx) / 4,
                 yt = y0 + my + k * (y1 - y0 - 2 * my) / 4;
    const int xp = static_cast<int>(col_of(xt)), yp = static_cast<int>(row_of(yt));
    if (!heat) {
      cv::line(img, cv::Point(xp, top), cv::Point(xp, top + ph), grey, 1);
      cv::line(img, cv::Point(left, yp), cv::Point(left + pw, yp), grey, 1);
    }
    cv::putText(img, tick_text(spec.log_x ? std::pow(10.0, xt) : xt),
                cv::Point(xp - 15, top + ph + 18), cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1,
                cv::LINE_AA);
    cv::putText(img, tick_text(spec.log_y ? std::pow(10.0, yt) : yt), cv::Point(5, yp + 4),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
  }
  cv::putText(img, spec.title, cv::Point(left, 25), cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1,
              cv::LINE_AA);
  cv::putText(img, spec.x_label, cv::Point(left + pw / 2 - 40, height - 12),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  cv::putText(img, spec.y_label, cv::Point(left + 5, top + 15), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              black, 1, cv::LINE_AA);

  // Series are clipped to the plot area.
  cv::Mat area = img(cv::Rect(left, top, pw, ph));
  const cv::Point origin(left, top);
  int legend_y = top + 35;
  for (const PlotSeries& s : spec.series) {
    const cv::Scalar c = colour_of(s.color_bgr);
    std::vector<cv::Point> poly;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!drawable(s.x[i], s.y[i])) continue;
      const cv::Point p = px(s.x[i], s.y[i]) - origin;
      if (s.line) {
        poly.push_back(p);
      } else if (i < s.dx.size() && i < s.dy.size()) {
        if (drawable(s.x[i] + s.dx[i], s.y[i] + s.dy[i]))
          cv::line(area, p, px(s.x[i] + s.dx[i], s.y[i] + s.dy[i]) - origin, c, 1, cv::LINE_AA);
      } else if (s.bar_width > 0) {
        const double base = spec.log_y ? std::pow(10.0, y0) : 0.0;
        cv::rectangle(area, px(s.x[i] - 0.5 * s.bar_width, base) - origin,
                      px(s.x[i] + 0.5 * s.bar_width, s.y[i]) - origin, c, cv::FILLED);
      } else {
        cv::circle(area, p, std::max(0, s.marker_px), c, cv::FILLED, cv::LINE_AA);
        if (i < s.y_error.size() && std::isfinite(s.y_error[i]) && !spec.log_y)
          cv::line(area, px(s.x[i], s.y[i] - s.y_error[i]) - origin,
                   px(s.x[i], s.y[i] + s.y_error[i]) - origin, c, 1);
      }
    }
    if (poly.size() > 1) cv::polylines(area, poly, false, c, 2, cv::LINE_AA);
    if (!s.label.empty()) {
      cv::putText(img, s.label, cv::Point(left + pw - 200, legend_y), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                  c, 1, cv::LINE_AA);
      legend_y += 16;
    }
  }
  try {
    if (!cv::imwrite(png_path.string(), img))
      return make_error("io_error", "cannot write " + png_path.string());
  } catch (const cv::Exception& e) {
    return make_error("io_error", "cannot write " + png_path.string() + ": " + e.what());
  }
  return {};
}

}  // namespace camlab::analysis
