// The capture folder: what is written is read back bit for bit, a cut-short capture is
// readable, and broken or hostile folders give specific errors.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "base/atomic_file.h"
#include "image/cameramodel_file.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"

namespace camlab::image {
namespace {

namespace fs = std::filesystem;

class CaptureFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_capture_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  static FrameSidecar sidecar(int bit_depth, uint64_t sequence) {
    FrameSidecar s;
    s.sequence = sequence;
    s.timestamp_ns = 1000 + static_cast<int64_t>(sequence) * 33'333'000;
    s.pixel_format = bit_depth > 8 ? "Y12" : "GREY";
    s.bit_depth = bit_depth;
    s.black_level_dn = 64;
    s.settings = {{"exposure_us", 1000.0 * (sequence + 1)}, {"focus_distance_m", INFINITY}};
    return s;
  }

  fs::path dir;
};

TEST_F(CaptureFolderTest, SixteenBitFramesRoundTripExactly) {
  auto writer = CaptureFolderWriter::create(dir, "render", {{"camera", "test"}}, {{"repeats", 1}});
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  cv::Mat frames[2] = {cv::Mat(48, 64, CV_16UC1), cv::Mat(48, 64, CV_16UC1)};
  cv::RNG rng(5);
  for (int k = 0; k < 2; ++k) {
    rng.fill(frames[k], cv::RNG::UNIFORM, 0, 4096);
    ASSERT_TRUE(writer->add_frame(frames[k], sidecar(12, k)).ok());
  }
  ASSERT_TRUE(writer->finish().ok());

  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_TRUE(folder->complete());
  ASSERT_EQ(folder->frames().size(), 2u);
  for (int k = 0; k < 2; ++k) {
    auto image = folder->load_image(k);
    ASSERT_TRUE(image.ok());
    EXPECT_EQ(image->type(), CV_16UC1);
    EXPECT_EQ(cv::norm(*image, frames[k], cv::NORM_INF), 0) << "lossless";
    auto meta = folder->load_sidecar(k);
    ASSERT_TRUE(meta.ok()) << meta.error().message;
    EXPECT_EQ(meta->sequence, static_cast<uint64_t>(k));
    EXPECT_EQ(meta->bit_depth, 12);
    EXPECT_DOUBLE_EQ(meta->settings["exposure_us"].get<double>(), 1000.0 * (k + 1));
    EXPECT_TRUE(meta->settings["focus_distance_m"].is_null()) << "infinity is JSON null";
  }
}

TEST_F(CaptureFolderTest, EightBitFramesAreEightBitPngs) {
  auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
  ASSERT_TRUE(writer.ok());
  cv::Mat frame(10, 10, CV_8UC1, cv::Scalar(200));
  ASSERT_TRUE(writer->add_frame(frame, sidecar(8, 0)).ok());
  // A 16-bit image for an 8-bit sidecar is a caller bug caught as an error, not a crash.
  EXPECT_FALSE(writer->add_frame(cv::Mat(10, 10, CV_16UC1), sidecar(8, 1)).ok());
  ASSERT_TRUE(writer->commit().ok()) << "a refused frame does not stop the writer";
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_EQ(folder->load_image(0)->type(), CV_8UC1);
}

TEST_F(CaptureFolderTest, ACaptureCutShortIsReadableAndSaysIncomplete) {
  {
    auto writer = CaptureFolderWriter::create(dir, "bracket", {}, {});
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->add_frame(cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)), sidecar(8, 0)).ok());
    // No finish(): the process "died" here.
  }
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_FALSE(folder->complete());
  EXPECT_EQ(folder->frames().size(), 1u);
  EXPECT_TRUE(folder->load_image(0).ok());
  // No temporary files are left behind by the atomic writes.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_NE(entry.path().filename().string()[0], '.') << entry.path();
}

// camlabd lists a running job's frames as soon as its manifest appears; the folder must open
// from that moment (the journal written second once answered 404 to a poll between the two).
TEST_F(CaptureFolderTest, AFolderOpensFromTheMomentItsManifestAppears) {
  constexpr int kFolders = 300;  // bounded: each creation is a few file operations
  std::atomic<int> created{-1};
  std::atomic<bool> done{false};
  std::string first_failure;
  int opened_while_new = 0;
  std::thread reader([&] {
    while (!done.load()) {
      const int k = created.load() + 1;  // the folder being created now, or next
      const fs::path candidate = dir / std::to_string(k);
      if (!fs::exists(candidate / "manifest.json")) continue;
      auto folder = CaptureFolder::open(candidate);
      if (!folder && first_failure.empty()) first_failure = folder.error().message;
      if (folder) ++opened_while_new;
    }
  });
  for (int k = 0; k < kFolders; ++k) {
    ASSERT_TRUE(CaptureFolderWriter::create(dir / std::to_string(k), "bracket", {}, {}).ok());
    created.store(k);
  }
  done.store(true);
  reader.join();
  EXPECT_TRUE(first_failure.empty()) << first_failure;
  EXPECT_GT(opened_while_new, 0) << "the reader never met a folder as it was made";
}

TEST_F(CaptureFolderTest, RefusesToOverwriteANonEmptyFolder) {
  fs::create_directories(dir);
  { std::ofstream(dir / "precious.txt") << "keep me"; }
  auto writer = CaptureFolderWriter::create(dir, "render", {}, {});
  ASSERT_FALSE(writer.ok());
  EXPECT_EQ(writer.error().code, "exists");
  EXPECT_TRUE(fs::exists(dir / "precious.txt"));
}

TEST_F(CaptureFolderTest, BrokenFoldersGiveSpecificErrors) {
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "not_a_capture");
  fs::create_directories(dir);
  { std::ofstream(dir / "manifest.json") << "{ not json"; }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "bad_manifest");
  {
    std::ofstream(dir / "manifest.json")
        << R"({"format": "camlab-capture", "version": 99, "frames": []})";
  }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "unsupported_version");
  {
    std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 1,
      "frames": [{"index": 0, "image": "../../etc/passwd", "sidecar": "a.json"}]})";
  }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "bad_manifest") << "paths must stay inside";
  {
    std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 1,
      "frames": [{"index": 0, "image": "frame_000000.png", "sidecar": "frame_000000.json"}]})";
    std::ofstream(dir / "frame_000000.png") << "this is not a PNG";
    std::ofstream(dir / "frame_000000.json") << R"({"sequence": 0})";
  }
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_EQ(folder->load_stored_image(0).error().code, "bad_image");
  EXPECT_EQ(folder->load_sidecar(0).error().code, "bad_sidecar");
  EXPECT_EQ(folder->load_image(0).error().code, "bad_sidecar") << "the sidecar says what it is";
  EXPECT_EQ(folder->load_image(5).error().code, "out_of_range");
}

// Found by the capture_folder fuzz harness: values of the wrong JSON type were converted
// (undefined behaviour for 1e300 as an int) or threw out of open(). Each is a clear error.
TEST_F(CaptureFolderTest, MistypedManifestAndSidecarValuesAreErrors) {
  fs::create_directories(dir);
  auto manifest = [&](const std::string& text) { std::ofstream(dir / "manifest.json") << text; };
  manifest(R"({"format": "camlab-capture", "version": 1e300, "frames": []})");
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "unsupported_version");
  manifest(R"({"format": "camlab-capture", "version": 3, "complete": "yes"})");
  { std::ofstream(dir / "frames.jsonl") << "x"; }
  auto complete = CaptureFolder::open(dir);
  ASSERT_FALSE(complete.ok());
  EXPECT_EQ(complete.error().code, "bad_manifest");
  EXPECT_NE(complete.error().message.find("\"complete\" must be true or false"), std::string::npos);
  manifest(R"({"format": "camlab-capture", "version": 1,
    "frames": [{"index": 1e300, "image": "a.png", "sidecar": "a.json"}]})");
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "bad_manifest");

  for (const char* sidecar : {R"({"sequence": 0, "timestamp_ns": 0, "bit_depth": 1e300})",
                              R"({"sequence": -1e300, "timestamp_ns": 0, "bit_depth": 8})",
                              R"({"sequence": 0, "timestamp_ns": 0, "bit_depth": 8,
                                  "black_level_dn": 1e300})"}) {
    auto read = frame_sidecar_from_json(nlohmann::json::parse(sidecar));
    ASSERT_FALSE(read.ok()) << sidecar;
    EXPECT_EQ(read.error().code, "bad_sidecar");
    EXPECT_NE(read.error().message.find("must be an integer"), std::string::npos);
  }
}

// Format version 2: Bayer mosaics, RGB and JPEG frames round trip with their colour keys;
// version 1 folders still read (as mono, linear, full scale); mono-only readers refuse
// colour frames by name rather than measure a filter pattern.

FrameSidecar mosaic_sidecar() {
  FrameSidecar s;
  s.pixel_format = "SGRBG12";
  s.delivered_format = "pgCC";
  s.layout = FrameLayout::kMosaic;
  s.cfa_pattern = "GRBG";
  s.bit_depth = 12;
  s.black_level_dn = 256;
  s.white_level_dn = 4000;
  return s;
}

TEST_F(CaptureFolderTest, MosaicRgbAndJpegFramesRoundTripWithTheirKeys) {
  auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
  ASSERT_TRUE(writer.ok());
  cv::Mat mosaic(6, 8, CV_16UC1);
  cv::randu(mosaic, 0, 4096);
  ASSERT_TRUE(writer->add_frame(mosaic, mosaic_sidecar()).ok());

  cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(10, 100, 250));
  FrameSidecar rgb;
  rgb.pixel_format = "RGB3";
  rgb.delivered_format = "NV12";
  rgb.layout = FrameLayout::kRgb;
  ASSERT_TRUE(writer->add_frame(bgr, rgb).ok());

  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
  FrameSidecar jpeg_side = rgb;
  jpeg_side.pixel_format = "MJPG";
  jpeg_side.delivered_format = "MJPG";
  jpeg_side.linear = false;
  ASSERT_TRUE(writer->add_jpeg_frame(jpeg, jpeg_side).ok());
  EXPECT_FALSE(writer->add_jpeg_frame(jpeg, rgb).ok()) << "a JPEG is never linear";
  ASSERT_TRUE(writer->finish().ok());

  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_EQ(folder->manifest()["version"], 3);
  EXPECT_EQ(folder->frames()[2].image_file, "frame_000002.jpg");
  // The JPEG is on disk byte for byte as delivered.
  std::ifstream in(dir / "frame_000002.jpg", std::ios::binary);
  std::vector<uint8_t> on_disk((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(on_disk, jpeg);

  auto m = folder->load_sidecar(0);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->layout, FrameLayout::kMosaic);
  EXPECT_EQ(m->cfa_pattern, "GRBG");
  EXPECT_EQ(m->white_level_dn, 4000);
  EXPECT_EQ(m->delivered_format, "pgCC");
  EXPECT_EQ(cv::norm(*folder->load_stored_image(0), mosaic, cv::NORM_INF), 0);
  EXPECT_EQ(folder->load_image(0).error().code, ErrorCode::kUnsupported);

  auto r = folder->load_stored_image(1);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->at<cv::Vec3b>(3, 3), cv::Vec3b(10, 100, 250)) << "B, G, R as written";
  EXPECT_EQ(folder->load_image(1).error().code, ErrorCode::kUnsupported);

  auto j = folder->load_sidecar(2);
  ASSERT_TRUE(j.ok());
  EXPECT_FALSE(j->linear);
  EXPECT_EQ(folder->load_image(2).error().code, ErrorCode::kNotLinear);
  auto decoded = folder->load_stored_image(2);
  ASSERT_TRUE(decoded.ok());
  EXPECT_LE(cv::norm(*decoded, bgr, cv::NORM_INF), 3.0);
}

TEST_F(CaptureFolderTest, VersionOneFoldersReadAsMonoLinearFullScale) {
  fs::create_directories(dir);
  cv::imwrite((dir / "frame_000000.png").string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(900)));
  std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 1,
    "kind": "single", "complete": true, "frame_count": 1,
    "frames": [{"index": 0, "image": "frame_000000.png", "sidecar": "frame_000000.json"}]})";
  std::ofstream(dir / "frame_000000.json") << R"({"sequence": 7, "timestamp_ns": 0,
    "pixel_format": "Y10", "bit_depth": 10, "black_level_dn": 16, "settings": {}})";
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  auto side = folder->load_sidecar(0);
  ASSERT_TRUE(side.ok()) << side.error().message;
  EXPECT_EQ(side->layout, FrameLayout::kMono);
  EXPECT_TRUE(side->linear);
  EXPECT_EQ(side->white_level_dn, 1023);
  auto image = folder->load_image(0);
  ASSERT_TRUE(image.ok()) << image.error().message;
  EXPECT_EQ(image->at<uint16_t>(2, 2), 900);
}

TEST_F(CaptureFolderTest, InconsistentColourKeysAreBadSidecars) {
  nlohmann::json base = {{"sequence", 0}, {"timestamp_ns", 0}, {"bit_depth", 10}};
  auto with = [&](nlohmann::json extra) {
    nlohmann::json j = base;
    j.update(extra);
    return frame_sidecar_from_json(j);
  };
  EXPECT_TRUE(with({{"layout", "mosaic"}, {"cfa_pattern", "BGGR"}}).ok());
  EXPECT_EQ(with({{"layout", "mosaic"}}).error().code, ErrorCode::kBadSidecar);
  EXPECT_EQ(with({{"layout", "mosaic"}, {"cfa_pattern", "RGBW"}}).error().code,
            ErrorCode::kBadSidecar);
  EXPECT_EQ(with({{"layout", "hexagonal"}}).error().code, ErrorCode::kBadSidecar);
  EXPECT_EQ(with({{"white_level_dn", 4095}}).error().code, ErrorCode::kBadSidecar)
      << "4095 does not fit in 10 bits";
  EXPECT_EQ(with({{"white_level_dn", 10}, {"black_level_dn", 64}}).error().code,
            ErrorCode::kBadSidecar);
}

// The curve a camera declared travels with each frame; a sidecar that contradicts itself
// or names no known curve is refused rather than read as light.
TEST(FrameSidecarTransfer, TheDeclaredCurveRoundTripsAndContradictionsAreRefused) {
  FrameSidecar yuyv;
  yuyv.pixel_format = "GREY";
  yuyv.delivered_format = "YUYV";
  yuyv.black_level_dn = 16;
  yuyv.white_level_dn = 235;
  yuyv.linear = false;
  yuyv.transfer = TransferFunction::kBt709;
  auto back = frame_sidecar_from_json(to_json(yuyv));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->transfer, TransferFunction::kBt709);
  EXPECT_FALSE(back->linear);

  nlohmann::json old = to_json(yuyv);
  old.erase("transfer");
  EXPECT_EQ(frame_sidecar_from_json(old)->transfer, TransferFunction::kOther)
      << "a non-linear frame from before the key: its curve is unknown";
  old["linear"] = true;
  EXPECT_EQ(frame_sidecar_from_json(old)->transfer, TransferFunction::kLinear);

  nlohmann::json bad = to_json(yuyv);
  bad["transfer"] = "gamma 2.2";
  EXPECT_EQ(frame_sidecar_from_json(bad).error().code, "bad_sidecar");
  bad["transfer"] = 2.2;
  EXPECT_EQ(frame_sidecar_from_json(bad).error().code, "bad_sidecar");
  bad["transfer"] = "srgb";
  bad["linear"] = true;
  EXPECT_EQ(frame_sidecar_from_json(bad).error().code, "bad_sidecar") << "linear and a curve";

  // Decoding: every code of the range to its light; an unknown curve is refused.
  cv::Mat codes(1, 4, CV_8UC1);
  codes.at<uint8_t>(0, 0) = 10;   // below black: no light
  codes.at<uint8_t>(0, 1) = 16;   // black
  codes.at<uint8_t>(0, 2) = 126;  // (126 - 16) / 219 = 0.502: BT.709 decodes to 0.2589
  codes.at<uint8_t>(0, 3) = 240;  // above white: clipped to white
  auto light = decode_to_light(codes, yuyv);
  ASSERT_TRUE(light.ok()) << light.error().message;
  EXPECT_TRUE(light->decoded);
  EXPECT_EQ(light->stored.at<uint16_t>(0, 0), 0);
  EXPECT_EQ(light->stored.at<uint16_t>(0, 1), 0);
  EXPECT_NEAR(light->stored.at<uint16_t>(0, 2) / 65535.0,
              std::pow((110.0 / 219.0 + 0.099) / 1.099, 1 / 0.45), 1e-5);
  EXPECT_EQ(light->stored.at<uint16_t>(0, 3), 65535);
  EXPECT_EQ(light->sidecar.transfer, TransferFunction::kLinear);
  EXPECT_EQ(light->sidecar.white_level_dn, 65535);
  yuyv.transfer = TransferFunction::kOther;
  EXPECT_EQ(decode_to_light(codes, yuyv).error().code, "not_linear");
}

TEST(FrameViews, CfaPlanesHoldTheSamplesOfEachColour) {
  // A mosaic whose every sample says its colour: R = 1000, G = 2000, B = 3000.
  const std::string cfa = "GBRG";
  cv::Mat mosaic(4, 6, CV_16UC1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) {
      const char c = cfa[static_cast<size_t>(2 * (y % 2) + x % 2)];
      mosaic.at<uint16_t>(y, x) = c == 'R' ? 1000 : c == 'G' ? 2000 : 3000;
    }
  FrameSidecar side;
  side.layout = FrameLayout::kMosaic;
  side.cfa_pattern = cfa;
  side.bit_depth = 12;
  auto planes = cfa_planes(mosaic, side);
  ASSERT_TRUE(planes.ok());
  for (int k = 0; k < 4; ++k) {
    const char c = planes->colours[static_cast<size_t>(k)];
    const double want = c == 'R' ? 1000 : c == 'G' ? 2000 : 3000;
    const cv::Mat& plane = planes->planes[static_cast<size_t>(k)];
    EXPECT_EQ(plane.size(), cv::Size(3, 2));
    double lo, hi;
    cv::minMaxLoc(plane, &lo, &hi);
    EXPECT_EQ(lo, want) << k;
    EXPECT_EQ(hi, want) << k;
  }
  // A flat grey through the demosaic keeps its weighted level (away from the border).
  auto lum = luminance_view(mosaic, side);
  ASSERT_TRUE(lum.ok());
  EXPECT_NEAR(lum->at<uint16_t>(2, 3), 0.299 * 1000 + 0.587 * 2000 + 0.114 * 3000, 2);
}

TEST(CameraModelText, PrintsEveryDoubleRoundTripExact) {
  CameraModelText model;
  model.lensmodel = "LENSMODEL_OPENCV4";
  model.intrinsics = {1000.0 / 3.0, 2000.0 / 7.0, 319.5, 239.5, -0.1 / 3, 1e-17, 0, 0};
  model.imagersize = {640, 480};
  const std::string text = to_cameramodel_text(model);
  for (double value : model.intrinsics) {
    char exact[40];
    std::snprintf(exact, sizeof exact, "%.17g", value);
    EXPECT_NE(text.find(exact), std::string::npos) << exact << " missing from\n" << text;
  }
  EXPECT_NE(text.find("'extrinsics'"), std::string::npos) << "mrcal 2.2's key";
}

}  // namespace
}  // namespace camlab::image
