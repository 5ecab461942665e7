#include "mock_device/v4l2/virtual_v4l2_formats.h"

#include "image/jpeg_codec.h"

namespace camlab::mock {

namespace {

// The kernel's names of the four orders, as in its format descriptions.
struct BayerOrder {
  const char* cfa;
  const char* rows;  // "RGRG/GBGB"
  uint32_t raw8, raw10, raw12, raw16, mipi10, mipi12;
};

constexpr BayerOrder kOrders[] = {
    {"RGGB", "RGRG/GBGB", V4L2_PIX_FMT_SRGGB8, V4L2_PIX_FMT_SRGGB10, V4L2_PIX_FMT_SRGGB12,
     V4L2_PIX_FMT_SRGGB16, V4L2_PIX_FMT_SRGGB10P, V4L2_PIX_FMT_SRGGB12P},
    {"BGGR", "BGBG/GRGR", V4L2_PIX_FMT_SBGGR8, V4L2_PIX_FMT_SBGGR10, V4L2_PIX_FMT_SBGGR12,
     V4L2_PIX_FMT_SBGGR16, V4L2_PIX_FMT_SBGGR10P, V4L2_PIX_FMT_SBGGR12P},
    {"GRBG", "GRGR/BGBG", V4L2_PIX_FMT_SGRBG8, V4L2_PIX_FMT_SGRBG10, V4L2_PIX_FMT_SGRBG12,
     V4L2_PIX_FMT_SGRBG16, V4L2_PIX_FMT_SGRBG10P, V4L2_PIX_FMT_SGRBG12P},
    {"GBRG", "GBGB/RGRG", V4L2_PIX_FMT_SGBRG8, V4L2_PIX_FMT_SGBRG10, V4L2_PIX_FMT_SGBRG12,
     V4L2_PIX_FMT_SGBRG16, V4L2_PIX_FMT_SGBRG10P, V4L2_PIX_FMT_SGBRG12P},
};

const BayerOrder& order_of(const std::string& cfa) {
  for (const BayerOrder& order : kOrders)
    if (cfa == order.cfa) return order;
  return kOrders[0];  // unreachable: the spec accepts only these four
}

// Bytes of one row of `width` samples, without padding (v4l2_fill_pixfmt's
// ALIGN(width, block) * bpp / bpp_div).
uint32_t row_bytes(FormatKind kind, uint32_t width) {
  switch (kind) {
    case FormatKind::kGrey:
    case FormatKind::kBayer8:
    case FormatKind::kNv12:
      return width;
    case FormatKind::kY16:
    case FormatKind::kYuyv:
    case FormatKind::kBayer16Low:
    case FormatKind::kBayer16High:
      return 2 * width;
    case FormatKind::kBayerMipi10:
      return (width + 3) / 4 * 5;
    case FormatKind::kBayerMipi12:
      return (width + 1) / 2 * 3;
    case FormatKind::kRgb24:
    case FormatKind::kBgr24:
      return 3 * width;
    case FormatKind::kMjpeg:
      return 0;
  }
  return 0;
}

}  // namespace

std::vector<OfferedFormat> offered_formats(const SensorSpec& sensor) {
  if (!sensor.is_colour())
    return {{V4L2_PIX_FMT_GREY, FormatKind::kGrey, 8, "8-bit Greyscale"},
            {V4L2_PIX_FMT_Y16, FormatKind::kY16, 16, "16-bit Greyscale"},
            {V4L2_PIX_FMT_YUYV, FormatKind::kYuyv, 8, "YUYV 4:2:2"}};
  const BayerOrder& order = order_of(sensor.cfa);
  const std::string rows = order.rows;
  std::vector<OfferedFormat> formats;
  formats.push_back({order.raw8, FormatKind::kBayer8, 8, "8-bit Bayer " + rows});
  if (sensor.bit_depth >= 10)
    formats.push_back({order.raw10, FormatKind::kBayer16Low, 10, "10-bit Bayer " + rows});
  if (sensor.bit_depth >= 12)
    formats.push_back({order.raw12, FormatKind::kBayer16Low, 12, "12-bit Bayer " + rows});
  formats.push_back({order.raw16, FormatKind::kBayer16High, 16, "16-bit Bayer " + rows});
  if (sensor.bit_depth >= 10)
    formats.push_back(
        {order.mipi10, FormatKind::kBayerMipi10, 10, "10-bit Bayer " + rows + " Packed"});
  if (sensor.bit_depth >= 12)
    formats.push_back(
        {order.mipi12, FormatKind::kBayerMipi12, 12, "12-bit Bayer " + rows + " Packed"});
  formats.push_back({V4L2_PIX_FMT_RGB24, FormatKind::kRgb24, 8, "24-bit RGB 8-8-8"});
  formats.push_back({V4L2_PIX_FMT_BGR24, FormatKind::kBgr24, 8, "24-bit BGR 8-8-8"});
  formats.push_back({V4L2_PIX_FMT_NV12, FormatKind::kNv12, 8, "Y/CbCr 4:2:0"});
  formats.push_back({V4L2_PIX_FMT_YUYV, FormatKind::kYuyv, 8, "YUYV 4:2:2"});
  formats.push_back({V4L2_PIX_FMT_MJPEG, FormatKind::kMjpeg, 8, "Motion-JPEG"});
  return formats;
}

uint32_t default_fourcc(const SensorSpec& sensor) {
  if (!sensor.is_colour()) return sensor.bit_depth > 8 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
  const BayerOrder& order = order_of(sensor.cfa);
  switch (sensor.bit_depth) {
    case 8:
      return order.raw8;
    case 10:
      return order.raw10;
    case 12:
      return order.raw12;
    default:
      return order.raw16;  // 9, 11 and 13..16 bits: every bit, MSB-aligned
  }
}

std::optional<FrameSize> frame_size(const OfferedFormat& format, const SensorSpec& sensor,
                                    uint32_t index) {
  if (index > 1) return std::nullopt;
  FrameSize size{static_cast<uint32_t>(sensor.width_px) >> index,
                 static_cast<uint32_t>(sensor.height_px) >> index};
  // YUYV pairs pixels; NV12's chroma covers 2x2 blocks.
  if (format.kind == FormatKind::kYuyv || format.kind == FormatKind::kNv12) size.width &= ~1u;
  if (format.kind == FormatKind::kNv12) size.height &= ~1u;
  return size;
}

void fill_pix_format(const OfferedFormat& format, FrameSize size, v4l2_pix_format* pix,
                     const IspSpec& isp) {
  const TransferFunction isp_transfer = isp.transfer;
  pix->pixelformat = format.fourcc;
  pix->width = size.width;
  pix->height = size.height;
  pix->field = V4L2_FIELD_NONE;
  pix->bytesperline = row_bytes(format.kind, size.width);
  switch (format.kind) {
    case FormatKind::kNv12:  // the chroma plane has the luma plane's stride
      pix->sizeimage = pix->bytesperline * size.height * 3 / 2;
      break;
    case FormatKind::kMjpeg:
      pix->sizeimage = static_cast<uint32_t>(
          image::jpeg_buffer_bound(static_cast<int>(size.width), static_cast<int>(size.height)));
      break;
    default:
      pix->sizeimage = pix->bytesperline * size.height;
      break;
  }
  // The kernel's core marks the extended fields (colour, transfer) valid in every reply.
  pix->priv = V4L2_PIX_FMT_PRIV_MAGIC;
  pix->flags = 0;
  // Raw samples declare no colour; the image processor's formats have sRGB primaries,
  // RGB at full range, YCbCr as BT.601 at limited range, JPEG (JFIF) BT.601 at full
  // range, and the ISP's curve: linear (no transfer function: the DN above black,
  // scaled), sRGB left at DEFAULT for the colour space to imply (as many drivers do), or
  // BT.709 said outright (as uvcvideo does from a camera's colour matching descriptor).
  pix->colorspace = V4L2_COLORSPACE_SRGB;
  pix->xfer_func = isp_transfer == TransferFunction::kSrgb    ? V4L2_XFER_FUNC_DEFAULT
                   : isp_transfer == TransferFunction::kBt709 ? V4L2_XFER_FUNC_709
                                                              : V4L2_XFER_FUNC_NONE;
  switch (format.kind) {
    case FormatKind::kGrey:
    case FormatKind::kY16:
    case FormatKind::kBayer8:
    case FormatKind::kBayer16Low:
    case FormatKind::kBayer16High:
    case FormatKind::kBayerMipi10:
    case FormatKind::kBayerMipi12:
      pix->colorspace = V4L2_COLORSPACE_RAW;
      pix->xfer_func = V4L2_XFER_FUNC_NONE;
      pix->ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
      pix->quantization = V4L2_QUANTIZATION_DEFAULT;
      break;
    case FormatKind::kRgb24:
    case FormatKind::kBgr24:
      pix->ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
      pix->quantization = V4L2_QUANTIZATION_FULL_RANGE;
      break;
    case FormatKind::kYuyv:
    case FormatKind::kNv12:
      pix->ycbcr_enc = V4L2_YCBCR_ENC_601;
      pix->quantization = V4L2_QUANTIZATION_LIM_RANGE;
      break;
    case FormatKind::kMjpeg:
      pix->ycbcr_enc = V4L2_YCBCR_ENC_601;
      pix->quantization = V4L2_QUANTIZATION_FULL_RANGE;
      break;
  }
  if (!isp.declares_colour_space) {
    pix->colorspace = V4L2_COLORSPACE_DEFAULT;
    pix->xfer_func = V4L2_XFER_FUNC_DEFAULT;
    pix->ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
    pix->quantization = V4L2_QUANTIZATION_DEFAULT;
  }
}

}  // namespace camlab::mock
