// The image check and window sampling the edge fits share (edge_fit_core.h).
#include "analysis/edge/edge_fit_core.h"

#include <limits>
#include <string>

#include "base/format.h"

namespace camlab::analysis::edge_fit {

Status check_fittable_image(const cv::Mat& image) {
  const int depth = image.depth();
  if (image.empty() || image.dims != 2 || image.channels() != 1 ||
      (depth != CV_8U && depth != CV_16U && depth != CV_32F && depth != CV_64F)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "image must be a non-empty single-channel CV_8U, CV_16U, CV_32F or "
                      "CV_64F matrix");
  }
  return {};
}

Result<std::vector<WindowPixel>> sample_window(const cv::Mat& image, const LineWindow& window,
                                               std::string_view window_name) {
  const double tx = std::cos(window.angle_rad), ty = std::sin(window.angle_rad);
  const double nx = -ty, ny = tx;
  const double half_length = window.half_length_px;

  // The bounding box of the window's four corners must lie within the pixel centres.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double min_x = kInf, max_x = -kInf, min_y = kInf, max_y = -kInf;
  for (double along : {-half_length, half_length}) {
    for (double across : {window.across_min_px, window.across_max_px}) {
      const double x = window.x_px + along * tx + across * nx;
      const double y = window.y_px + along * ty + across * ny;
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
  }
  constexpr double kSlack_px = 1e-9;
  if (min_x < -kSlack_px || min_y < -kSlack_px || max_x > image.cols - 1 + kSlack_px ||
      max_y > image.rows - 1 + kSlack_px) {
    return make_error(
        ErrorCode::kWindowOutsideImage,
        std::string(window_name) + " spans x " + format_significant(min_x, 3) + ".." +
            format_significant(max_x, 3) + ", y " + format_significant(min_y, 3) + ".." +
            format_significant(max_y, 3) + " px but the image's pixel centres span 0.." +
            std::to_string(image.cols - 1) + ", 0.." + std::to_string(image.rows - 1));
  }

  const cv::Range rows(static_cast<int>(std::ceil(min_y - kSlack_px)),
                       static_cast<int>(std::floor(max_y + kSlack_px)) + 1);
  const cv::Range cols(static_cast<int>(std::ceil(min_x - kSlack_px)),
                       static_cast<int>(std::floor(max_x + kSlack_px)) + 1);
  cv::Mat box;  // the bounding box in doubles, whatever the image's depth
  image(rows, cols).convertTo(box, CV_64F);
  std::vector<WindowPixel> pixels;
  pixels.reserve(box.total());
  for (int row = rows.start; row < rows.end; ++row) {
    for (int col = cols.start; col < cols.end; ++col) {
      const double dx = col - window.x_px, dy = row - window.y_px;
      const double along = dx * tx + dy * ty, across = dx * nx + dy * ny;
      const double value = box.at<double>(row - rows.start, col - cols.start);
      if (std::fabs(along) > half_length || across < window.across_min_px ||
          across > window.across_max_px || !std::isfinite(value)) {
        continue;
      }
      pixels.push_back({col, row, value, across});
    }
  }
  return pixels;
}

}  // namespace camlab::analysis::edge_fit
