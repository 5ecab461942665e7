#include "image/frame_views.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace camlab::image {

namespace {

// OpenCV names a Bayer pattern by the second row's second and third samples, so V4L2's
// RGGB is OpenCV's "BG".
int demosaic_to_bgr_code(const std::string& cfa) {
  if (cfa == "RGGB") return cv::COLOR_BayerBG2BGR;
  if (cfa == "BGGR") return cv::COLOR_BayerRG2BGR;
  if (cfa == "GRBG") return cv::COLOR_BayerGB2BGR;
  return cv::COLOR_BayerGR2BGR;  // GBRG
}

}  // namespace

Result<cv::Mat> picture_view(const cv::Mat& stored, const FrameSidecar& sidecar) {
  if (stored.empty()) return make_error("bad_image", "the frame is empty");
  switch (sidecar.layout) {
    case FrameLayout::kMono:
      if (stored.channels() != 1)
        return make_error("bad_image",
                          "a mono frame with " + std::to_string(stored.channels()) + " channels");
      return stored;
    case FrameLayout::kMosaic: {
      if (stored.channels() != 1 || !is_bayer_pattern(sidecar.cfa_pattern))
        return make_error("bad_image", "a mosaic frame must be one channel with a Bayer pattern");
      if (stored.rows < 2 || stored.cols < 2)
        return make_error("bad_image", "a mosaic frame needs at least 2x2 samples");
      cv::Mat bgr;
      cv::cvtColor(stored, bgr, demosaic_to_bgr_code(sidecar.cfa_pattern));
      return bgr;
    }
    case FrameLayout::kRgb:
      if (stored.channels() != 3)
        return make_error("bad_image",
                          "an rgb frame with " + std::to_string(stored.channels()) + " channels");
      return stored;
  }
  return make_error("bad_image", "unknown frame layout");
}

Result<cv::Mat> luminance_view(const cv::Mat& stored, const FrameSidecar& sidecar) {
  auto picture = picture_view(stored, sidecar);
  if (!picture || picture->channels() == 1) return picture;
  cv::Mat grey;
  cv::cvtColor(*picture, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

Result<LightFrame> decode_to_light(const cv::Mat& stored, const FrameSidecar& sidecar) {
  if (sidecar.transfer == TransferFunction::kLinear) return LightFrame{stored, sidecar, false};
  if (!is_decodable(sidecar.transfer)) return check_mono_linear(sidecar, "the frame").error();
  if (stored.depth() != CV_8U && stored.depth() != CV_16U)
    return make_error("bad_image", "only 8- and 16-bit frames are decoded to light");
  const int black = sidecar.black_level_dn;
  const int white = sidecar.white_level_dn > 0 ? sidecar.white_level_dn
                                               : (1 << std::clamp(sidecar.bit_depth, 1, 16)) - 1;
  if (white <= black)
    return make_error("bad_sidecar", "white level " + std::to_string(white) +
                                         " DN is not above the black level " +
                                         std::to_string(black) + " DN");
  // One entry per code the stored depth can hold.
  std::vector<uint16_t> table(stored.depth() == CV_8U ? 256 : 65536);
  for (size_t code = 0; code < table.size(); ++code) {
    const double v = (static_cast<double>(code) - black) / (white - black);
    table[code] =
        static_cast<uint16_t>(std::lround(65535.0 * decode_to_light(sidecar.transfer, v)));
  }
  LightFrame out;
  out.stored.create(stored.size(), CV_MAKETYPE(CV_16U, stored.channels()));
  const int samples = stored.cols * stored.channels();
  for (int y = 0; y < stored.rows; ++y) {
    uint16_t* row = out.stored.ptr<uint16_t>(y);
    if (stored.depth() == CV_8U) {
      const uint8_t* in = stored.ptr<uint8_t>(y);
      for (int x = 0; x < samples; ++x) row[x] = table[in[x]];
    } else {
      const uint16_t* in = stored.ptr<uint16_t>(y);
      for (int x = 0; x < samples; ++x) row[x] = table[in[x]];
    }
  }
  out.sidecar = light_sidecar(sidecar);
  out.decoded = true;
  return out;
}

FrameSidecar light_sidecar(const FrameSidecar& sidecar) {
  if (!is_decodable(sidecar.transfer) || sidecar.transfer == TransferFunction::kLinear)
    return sidecar;
  FrameSidecar out = sidecar;
  out.bit_depth = 16;
  out.black_level_dn = 0;
  out.white_level_dn = 65535;
  out.transfer = TransferFunction::kLinear;
  out.linear = sidecar.pixel_format != "MJPG" && sidecar.pixel_format != "JPEG";
  return out;
}

Result<CfaPlanes> cfa_planes(const cv::Mat& stored, const FrameSidecar& sidecar) {
  if (sidecar.layout != FrameLayout::kMosaic || !is_bayer_pattern(sidecar.cfa_pattern))
    return make_error("unsupported", "only a raw Bayer mosaic has colour planes");
  if (stored.channels() != 1 || stored.rows < 2 || stored.cols < 2)
    return make_error("bad_image", "a mosaic frame must be one channel of at least 2x2 samples");
  const int rows = stored.rows / 2, cols = stored.cols / 2;
  CfaPlanes out;
  for (int k = 0; k < 4; ++k) {
    out.colours[static_cast<size_t>(k)] = sidecar.cfa_pattern[static_cast<size_t>(k)];
    cv::Mat& plane = out.planes[static_cast<size_t>(k)];
    plane.create(rows, cols, stored.type());
    const int dy = k / 2, dx = k % 2;
    for (int y = 0; y < rows; ++y) {
      if (stored.depth() == CV_8U) {
        const uint8_t* in = stored.ptr<uint8_t>(2 * y + dy);
        uint8_t* row = plane.ptr<uint8_t>(y);
        for (int x = 0; x < cols; ++x) row[x] = in[2 * x + dx];
      } else {
        const uint16_t* in = stored.ptr<uint16_t>(2 * y + dy);
        uint16_t* row = plane.ptr<uint16_t>(y);
        for (int x = 0; x < cols; ++x) row[x] = in[2 * x + dx];
      }
    }
  }
  return out;
}

}  // namespace camlab::image
