// What the virtual V4L2 device offers for a colour and a monochrome camera: the formats in
// the sensor's own CFA order and depth, their sizes, their bytesperline and sizeimage as
// the kernel computes them (written out here from the formats' documented layouts), and
// colorspace fields that agree with the data (RAW for raw samples, linear sRGB at full
// range for RGB, BT.601 limited range for YUYV and NV12, full range for JPEG).
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <memory>
#include <string>
#include <vector>

#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

std::string fourcc_text(uint32_t fourcc) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i)
    s[static_cast<size_t>(i)] = static_cast<char>((fourcc >> (8 * i)) & 0xff);
  return s;
}

class Formats : public ::testing::Test {
 protected:
  void open(const nlohmann::json& camera_json) {
    if (device) device->close_file(file);
    auto camera = parse_camera_spec(camera_json);
    auto scene = parse_scene_spec(testing::uniform_scene_json());
    ASSERT_TRUE(camera.ok() && scene.ok()) << (camera.ok() ? "" : camera.error().message);
    VirtualDeviceOptions options;
    options.realtime = false;
    auto created = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(created.ok());
    device = std::move(*created);
    file = device->open_file(true);
    ASSERT_GT(file, 0);
  }
  void TearDown() override {
    if (device) device->close_file(file);
  }

  std::vector<v4l2_fmtdesc> enumerate() {
    std::vector<v4l2_fmtdesc> out;
    for (uint32_t i = 0;; ++i) {
      v4l2_fmtdesc desc{};
      desc.index = i;
      desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      if (device->ioctl(file, VIDIOC_ENUM_FMT, &desc) != 0) break;
      out.push_back(desc);
    }
    return out;
  }
  std::vector<std::string> fourccs() {
    std::vector<std::string> out;
    for (const auto& d : enumerate()) out.push_back(fourcc_text(d.pixelformat));
    return out;
  }
  v4l2_pix_format set(uint32_t fourcc, uint32_t width, uint32_t height) {
    v4l2_format f{};
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    f.fmt.pix.pixelformat = fourcc;
    f.fmt.pix.width = width;
    f.fmt.pix.height = height;
    EXPECT_EQ(device->ioctl(file, VIDIOC_S_FMT, &f), 0);
    return f.fmt.pix;
  }

  std::unique_ptr<VirtualV4l2Device> device;
  int file = 0;
};

TEST_F(Formats, ABayerSensorOffersItsOwnOrderInEveryDepthItHasThenTheIspsFormats) {
  const std::vector<std::pair<const char*, std::vector<std::string>>> orders = {
      {"RGGB", {"RGGB", "RG10", "RG12", "RG16", "pRAA", "pRCC"}},
      {"BGGR", {"BA81", "BG10", "BG12", "BYR2", "pBAA", "pBCC"}},
      {"GRBG", {"GRBG", "BA10", "BA12", "GR16", "pgAA", "pgCC"}},
      {"GBRG", {"GBRG", "GB10", "GB12", "GB16", "pGAA", "pGCC"}},
  };
  for (const auto& [cfa, raw] : orders) {
    open(testing::colour_camera_json(64, 48, cfa));  // a 12-bit sensor
    std::vector<std::string> want = raw;
    for (const char* isp : {"RGB3", "BGR3", "NV12", "YUYV", "MJPG"}) want.push_back(isp);
    EXPECT_EQ(fourccs(), want) << cfa;
  }
  // A 10-bit sensor has no 12-bit formats; 16 bits carry any depth (MSB-aligned).
  nlohmann::json ten_bit = testing::colour_camera_json(64, 48, "RGGB");
  ten_bit["sensor"]["bit_depth"] = 10;
  ten_bit["sensor"]["black_level_dn"] = 16;
  open(ten_bit);
  EXPECT_EQ(fourccs(), (std::vector<std::string>{"RGGB", "RG10", "RG16", "pRAA", "RGB3", "BGR3",
                                                 "NV12", "YUYV", "MJPG"}));
}

TEST_F(Formats, AMonochromeSensorKeepsGreyY16AndYuyv) {
  open(testing::pinhole_camera_json(64, 48));
  EXPECT_EQ(fourccs(), (std::vector<std::string>{"GREY", "Y16 ", "YUYV"}));
}

TEST_F(Formats, DescriptionsAreTheKernelsAndOnlyJpegIsCompressed) {
  open(testing::colour_camera_json(64, 48, "GRBG"));
  for (const auto& d : enumerate()) {
    const std::string name = reinterpret_cast<const char*>(d.description);
    EXPECT_EQ((d.flags & V4L2_FMT_FLAG_COMPRESSED) != 0, d.pixelformat == V4L2_PIX_FMT_MJPEG)
        << name;
    // v4l2-compliance checks each against the kernel's v4l_fill_fmtdesc.
    const std::pair<uint32_t, const char*> kernel_names[] = {
        {V4L2_PIX_FMT_SGRBG8, "8-bit Bayer GRGR/BGBG"},
        {V4L2_PIX_FMT_SGRBG10P, "10-bit Bayer GRGR/BGBG Packed"},
        {V4L2_PIX_FMT_SGRBG16, "16-bit Bayer GRGR/BGBG"},
        {V4L2_PIX_FMT_NV12, "Y/CbCr 4:2:0"},
        {V4L2_PIX_FMT_MJPEG, "Motion-JPEG"}};
    for (const auto& [fourcc, kernel_name] : kernel_names) {
      if (d.pixelformat == fourcc) {
        EXPECT_EQ(name, kernel_name);
      }
    }
  }
}

TEST_F(Formats, TheDeviceStartsInTheSensorsRawFormatAndFallsBackToIt) {
  open(testing::colour_camera_json(64, 48, "BGGR"));
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  ASSERT_EQ(device->ioctl(file, VIDIOC_G_FMT, &f), 0);
  EXPECT_EQ(f.fmt.pix.pixelformat, V4L2_PIX_FMT_SBGGR12) << "12 bits, unpacked";
  EXPECT_EQ(set(V4L2_PIX_FMT_GREY, 64, 48).pixelformat, V4L2_PIX_FMT_SBGGR12)
      << "a Bayer sensor has no GREY";
  EXPECT_EQ(set(V4L2_PIX_FMT_SRGGB8, 64, 48).pixelformat, V4L2_PIX_FMT_SBGGR12)
      << "nor another order";
}

struct Layout {
  uint32_t fourcc;
  uint32_t bytesperline;  // at 66 x 50 (odd multiples of 2: packing pads, 4:2:0 halves)
  uint32_t sizeimage;
  uint32_t colorspace, xfer_func, ycbcr_enc, quantization;
};

TEST_F(Formats, BytesPerLineSizeImageAndColorspaceAsTheFormatsDefineThem) {
  open(testing::colour_camera_json(66, 50, "RGGB"));
  // Written out from the layouts: 10P packs 4 samples in 5 bytes (66 -> 17 groups), 12P 2
  // in 3; NV12 is a luma plane and a half-height chroma plane of the same stride.
  const Layout layouts[] = {
      {V4L2_PIX_FMT_SRGGB8, 66, 66 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_SRGGB10, 132, 132 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_SRGGB12, 132, 132 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_SRGGB16, 132, 132 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_SRGGB10P, 85, 85 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_SRGGB12P, 99, 99 * 50, V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT},
      {V4L2_PIX_FMT_RGB24, 198, 198 * 50, V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_FULL_RANGE},
      {V4L2_PIX_FMT_BGR24, 198, 198 * 50, V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_FULL_RANGE},
      {V4L2_PIX_FMT_NV12, 66, 66 * 50 + 66 * 25, V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_601, V4L2_QUANTIZATION_LIM_RANGE},
      {V4L2_PIX_FMT_YUYV, 132, 132 * 50, V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_NONE,
       V4L2_YCBCR_ENC_601, V4L2_QUANTIZATION_LIM_RANGE},
  };
  for (const Layout& want : layouts) {
    const v4l2_pix_format pix = set(want.fourcc, 66, 50);
    const std::string name = fourcc_text(want.fourcc);
    EXPECT_EQ(pix.pixelformat, want.fourcc) << name;
    EXPECT_EQ(pix.width, 66u) << name;
    EXPECT_EQ(pix.height, 50u) << name;
    EXPECT_EQ(pix.bytesperline, want.bytesperline) << name;
    EXPECT_EQ(pix.sizeimage, want.sizeimage) << name;
    EXPECT_EQ(pix.field, V4L2_FIELD_NONE) << name;
    EXPECT_EQ(pix.colorspace, want.colorspace) << name;
    EXPECT_EQ(pix.xfer_func, want.xfer_func) << name;
    EXPECT_EQ(pix.ycbcr_enc, want.ycbcr_enc) << name;
    EXPECT_EQ(pix.quantization, want.quantization) << name;
  }
  // MJPEG: no lines; sizeimage bounds any JPEG of the size (at least the raw RGB's bytes).
  const v4l2_pix_format jpeg = set(V4L2_PIX_FMT_MJPEG, 66, 50);
  EXPECT_EQ(jpeg.bytesperline, 0u);
  EXPECT_GE(jpeg.sizeimage, 66u * 50 * 3);
  EXPECT_EQ(jpeg.ycbcr_enc, V4L2_YCBCR_ENC_601);
  EXPECT_EQ(jpeg.quantization, V4L2_QUANTIZATION_FULL_RANGE);
}

TEST_F(Formats, BinnedSizesAreHalfAndYuvFormatsTakeEvenOnes) {
  open(testing::colour_camera_json(66, 50, "RGGB"));  // binned: 33 x 25
  for (uint32_t fourcc :
       {V4L2_PIX_FMT_SRGGB12P, V4L2_PIX_FMT_RGB24, V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_YUYV}) {
    v4l2_frmsizeenum size{};
    size.pixel_format = fourcc;
    size.index = 1;
    ASSERT_EQ(device->ioctl(file, VIDIOC_ENUM_FRAMESIZES, &size), 0);
    const bool even_width = fourcc == V4L2_PIX_FMT_NV12 || fourcc == V4L2_PIX_FMT_YUYV;
    EXPECT_EQ(size.discrete.width, even_width ? 32u : 33u) << fourcc_text(fourcc);
    EXPECT_EQ(size.discrete.height, fourcc == V4L2_PIX_FMT_NV12 ? 24u : 25u) << fourcc_text(fourcc);
    const v4l2_pix_format pix = set(fourcc, 30, 20);  // nearer the binned size
    EXPECT_EQ(pix.width, size.discrete.width);
    EXPECT_EQ(pix.height, size.discrete.height);
    // The sizes it lists are the ones it has intervals for.
    v4l2_frmivalenum interval{};
    interval.pixel_format = fourcc;
    interval.width = size.discrete.width;
    interval.height = size.discrete.height;
    EXPECT_EQ(device->ioctl(file, VIDIOC_ENUM_FRAMEINTERVALS, &interval), 0);
    interval.width += 1;
    EXPECT_EQ(device->ioctl(file, VIDIOC_ENUM_FRAMEINTERVALS, &interval), -EINVAL);
  }
  v4l2_frmsizeenum size{};
  size.pixel_format = V4L2_PIX_FMT_GREY;  // not offered by a Bayer sensor
  EXPECT_EQ(device->ioctl(file, VIDIOC_ENUM_FRAMESIZES, &size), -EINVAL);
}

TEST_F(Formats, MonochromeYuyvDeclaresTheLimitedRangeItCarries) {
  open(testing::pinhole_camera_json(64, 48));
  const v4l2_pix_format yuyv = set(V4L2_PIX_FMT_YUYV, 64, 48);
  EXPECT_EQ(yuyv.colorspace, V4L2_COLORSPACE_SRGB);
  EXPECT_EQ(yuyv.ycbcr_enc, V4L2_YCBCR_ENC_601);
  EXPECT_EQ(yuyv.quantization, V4L2_QUANTIZATION_LIM_RANGE);
  const v4l2_pix_format grey = set(V4L2_PIX_FMT_GREY, 64, 48);
  EXPECT_EQ(grey.colorspace, V4L2_COLORSPACE_RAW);
  EXPECT_EQ(grey.bytesperline, 64u);
}

}  // namespace
}  // namespace camlab::mock
