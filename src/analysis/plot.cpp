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

std::string tick_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

}  // namespace

Status write_plot(const std::filesystem::path& png_path, const PlotSpec& spec) {
  auto tx = [&](double v) { return spec.log_x ? std::log10(v) : v; };
  auto ty = [&](double v) { return spec.log_y ? std::log10(v) : v; };
  auto drawable = [&](double x, double y) {
    return std::isfinite(x) && std::isfinite(y) && (!spec.log_x || x > 0) && (!spec.log_y || y > 0);
  };
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const PlotSeries& s : spec.series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!drawable(s.x[i], s.y[i])) continue;
      const double e = i < s.y_error.size() && std::isfinite(s.y_error[i]) ? s.y_error[i] : 0.0;
      x0 = std::min(x0, tx(s.x[i]));
      x1 = std::max(x1, tx(s.x[i]));
      y0 = std::min(y0, spec.log_y ? ty(s.y[i]) : s.y[i] - e);
      y1 = std::max(y1, spec.log_y ? ty(s.y[i]) : s.y[i] + e);
    }
  if (!(x1 >= x0) || !(y1 >= y0)) return make_error("empty_plot", "nothing to plot in " + spec.title);
  if (x1 - x0 < 1e-12) { x0 -= 0.5; x1 += 0.5; }
  if (y1 - y0 < 1e-12) { y0 -= 0.5; y1 += 0.5; }
  const double mx = 0.05 * (x1 - x0), my = 0.08 * (y1 - y0);
  x0 -= mx; x1 += mx; y0 -= my; y1 += my;

  const int width = 640, height = 420, left = 70, right = 20, top = 40, bottom = 50;
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](double x, double y) {
    return cv::Point(static_cast<int>(left + (tx(x) - x0) / (x1 - x0) * (width - left - right)),
                     static_cast<int>(height - bottom - (ty(y) - y0) / (y1 - y0) * (height - top - bottom)));
  };
  auto py_lin = [&](double yt) {
    return static_cast<int>(height - bottom - (yt - y0) / (y1 - y0) * (height - top - bottom));
  };
  const cv::Scalar black(0, 0, 0), grey(200, 200, 200);
  cv::rectangle(img, cv::Point(left, top), cv::Point(width - right, height - bottom), black, 1);
  for (int k = 0; k <= 4; ++k) {
    const double xt = x0 + mx + k * (x1 - x0 - 2 * mx) / 4, yt = y0 + my + k * (y1 - y0 - 2 * my) / 4;
    const int xp = static_cast<int>(left + (xt - x0) / (x1 - x0) * (width - left - right));
    const int yp = py_lin(yt);
    cv::line(img, cv::Point(xp, top), cv::Point(xp, height - bottom), grey, 1);
    cv::line(img, cv::Point(left, yp), cv::Point(width - right, yp), grey, 1);
    cv::putText(img, tick_text(spec.log_x ? std::pow(10.0, xt) : xt), cv::Point(xp - 15, height - bottom + 18),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
    cv::putText(img, tick_text(spec.log_y ? std::pow(10.0, yt) : yt), cv::Point(5, yp + 4),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
  }
  cv::putText(img, spec.title, cv::Point(left, 25), cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1, cv::LINE_AA);
  cv::putText(img, spec.x_label, cv::Point(width / 2 - 40, height - 12), cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  cv::putText(img, spec.y_label, cv::Point(left + 5, top + 15), cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  int legend_y = top + 35;
  for (const PlotSeries& s : spec.series) {
    const cv::Scalar c((s.color_bgr >> 16) & 255, (s.color_bgr >> 8) & 255, s.color_bgr & 255);
    std::vector<cv::Point> poly;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!drawable(s.x[i], s.y[i])) continue;
      const cv::Point p = px(s.x[i], s.y[i]);
      if (s.line) {
        poly.push_back(p);
        continue;
      }
      cv::circle(img, p, 3, c, cv::FILLED, cv::LINE_AA);
      if (i < s.y_error.size() && std::isfinite(s.y_error[i]) && !spec.log_y) {
        cv::line(img, cv::Point(p.x, py_lin(s.y[i] - s.y_error[i])),
                 cv::Point(p.x, py_lin(s.y[i] + s.y_error[i])), c, 1);
      }
    }
    if (poly.size() > 1) cv::polylines(img, poly, false, c, 2, cv::LINE_AA);
    if (!s.label.empty()) {
      cv::putText(img, s.label, cv::Point(width - right - 200, legend_y), cv::FONT_HERSHEY_SIMPLEX, 0.4, c, 1, cv::LINE_AA);
      legend_y += 16;
    }
  }
  try {
    if (!cv::imwrite(png_path.string(), img)) return make_error("io_error", "cannot write " + png_path.string());
  } catch (const cv::Exception& e) {
    return make_error("io_error", "cannot write " + png_path.string() + ": " + e.what());
  }
  return {};
}

}  // namespace camlab::analysis
