#include "image/pixel_format.h"

#include <algorithm>

namespace camlab::image {

namespace {

using L = FrameLayout;
using P = SamplePacking;

// Four Bayer formats per depth and packing, in V4L2's order BGGR, GBRG, GRBG, RGGB.
void add_bayer(std::vector<PixelFormatInfo>& table, const char* const (&fourccs)[4],
               const char* const (&names)[4], P packing, int bits) {
  static constexpr const char* kPatterns[4] = {"BGGR", "GBRG", "GRBG", "RGGB"};
  for (int i = 0; i < 4; ++i)
    table.push_back({fourccs[i], names[i], L::kMosaic, packing, bits, kPatterns[i], true});
}

std::vector<PixelFormatInfo> build_table() {
  std::vector<PixelFormatInfo> t = {
      {"GREY", "GREY", L::kMono, P::k8, 8, "", true},
      {"Y16 ", "Y16", L::kMono, P::k16High, 16, "", true},
      {"Y10P", "Y10P", L::kMono, P::kMipi10, 10, "", true},
      {"Y12P", "Y12P", L::kMono, P::kMipi12, 12, "", true},
      {"YUYV", "YUYV", L::kMono, P::kYuyv, 8, "", true},
      {"RGB3", "RGB24", L::kRgb, P::kRgb24, 8, "", true},
      {"BGR3", "BGR24", L::kRgb, P::kBgr24, 8, "", true},
      {"NV12", "NV12", L::kRgb, P::kNv12, 8, "", true},
      {"YU12", "YUV420", L::kRgb, P::kYuv420, 8, "", true},
      {"MJPG", "MJPEG", L::kRgb, P::kJpeg, 8, "", false},
      {"JPEG", "JPEG", L::kRgb, P::kJpeg, 8, "", false},
  };
  add_bayer(t, {"BA81", "GBRG", "GRBG", "RGGB"}, {"SBGGR8", "SGBRG8", "SGRBG8", "SRGGB8"}, P::k8,
            8);
  add_bayer(t, {"BG10", "GB10", "BA10", "RG10"}, {"SBGGR10", "SGBRG10", "SGRBG10", "SRGGB10"},
            P::k16Low, 10);
  add_bayer(t, {"BG12", "GB12", "BA12", "RG12"}, {"SBGGR12", "SGBRG12", "SGRBG12", "SRGGB12"},
            P::k16Low, 12);
  add_bayer(t, {"BYR2", "GB16", "GR16", "RG16"}, {"SBGGR16", "SGBRG16", "SGRBG16", "SRGGB16"},
            P::k16High, 16);
  add_bayer(t, {"pBAA", "pGAA", "pgAA", "pRAA"}, {"SBGGR10P", "SGBRG10P", "SGRBG10P", "SRGGB10P"},
            P::kMipi10, 10);
  add_bayer(t, {"pBCC", "pGCC", "pgCC", "pRCC"}, {"SBGGR12P", "SGBRG12P", "SGRBG12P", "SRGGB12P"},
            P::kMipi12, 12);
  return t;
}

}  // namespace

const std::vector<PixelFormatInfo>& capturable_pixel_formats() {
  static const std::vector<PixelFormatInfo> table = build_table();
  return table;
}

std::optional<PixelFormatInfo> pixel_format_info(std::string_view fourcc) {
  const auto& table = capturable_pixel_formats();
  auto it = std::find_if(table.begin(), table.end(),
                         [&](const PixelFormatInfo& f) { return f.fourcc == fourcc; });
  if (it == table.end()) return std::nullopt;
  return *it;
}

std::string capturable_fourcc_list() {
  std::string list;
  for (const auto& f : capturable_pixel_formats()) {
    if (!list.empty()) list += ", ";
    std::string_view code = f.fourcc;
    while (!code.empty() && code.back() == ' ') code.remove_suffix(1);
    list += code;
  }
  return list;
}

uint64_t packed_row_bytes(const PixelFormatInfo& format, uint32_t width) {
  const uint64_t w = width;
  switch (format.packing) {
    case P::k8:
    case P::kNv12:
    case P::kYuv420:
      return w;
    case P::k16Low:
    case P::k16High:
    case P::kYuyv:
      return 2 * w;
    case P::kMipi10:  // whole groups: a short last group is padded to 4 samples
      return (w + 3) / 4 * 5;
    case P::kMipi12:  // whole groups of 2 samples
      return (w + 1) / 2 * 3;
    case P::kRgb24:
    case P::kBgr24:
      return 3 * w;
    case P::kJpeg:
      return 0;
  }
  return 0;
}

uint64_t frame_bytes(const PixelFormatInfo& format, uint32_t width, uint32_t height,
                     uint32_t bytes_per_line) {
  const uint64_t row = packed_row_bytes(format, width);
  if (row == 0 || width == 0 || height == 0) return 0;
  const uint64_t stride = std::max<uint64_t>(row, bytes_per_line);
  const uint64_t h = height, chroma_rows = (h + 1) / 2;
  switch (format.packing) {
    case P::kNv12:  // the chroma plane has the luma plane's stride
      return stride * h + stride * chroma_rows;
    case P::kYuv420:  // two chroma planes at half the stride
      return stride * h + 2 * ((stride + 1) / 2) * chroma_rows;
    default:  // the last row need not be padded
      return stride * (h - 1) + row;
  }
}

bool is_bayer_pattern(std::string_view cfa) {
  return cfa == "RGGB" || cfa == "BGGR" || cfa == "GRBG" || cfa == "GBRG";
}

int cfa_colour_at(std::string_view cfa, int x, int y) {
  const char c = cfa[static_cast<size_t>(2 * (y & 1) + (x & 1))];
  return c == 'R' ? 0 : c == 'G' ? 1 : 2;
}

std::string_view mono_pixel_format(int bit_depth) {
  switch (bit_depth) {
    case 8:
      return "GREY";
    case 10:
      return "Y10";
    case 12:
      return "Y12";
    case 14:
      return "Y14";
    default:
      return "Y16";
  }
}

}  // namespace camlab::image
