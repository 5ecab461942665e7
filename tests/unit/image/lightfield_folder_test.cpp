// The light-field folder: views, lenslet and white images and the depth truth read back
// exactly; lightfield.json's every check gives a specific error; PFM round trips.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include <opencv2/core.hpp>

#include "base/atomic_file.h"
#include "image/lightfield_folder.h"
#include "image/pfm.h"
#include "image/pixel_format.h"

namespace camlab::image {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class LightFieldFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_lightfield_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  static LightFieldDescription description() {
    LightFieldDescription d;
    d.views_u = d.views_v = 2;
    d.lattice = {"hex", 0.9, 0.5};
    d.optics = {8.0, 2.0, 8.065, std::numeric_limits<double>::infinity(), 4.0, {15.75, 10.8}};
    d.truth = {{"microlens_grid", "hex"}};
    return d;
  }
  static FrameSidecar sidecar() {
    FrameSidecar s;
    s.pixel_format = std::string(mono_pixel_format(12));
    s.bit_depth = 12;
    s.black_level_dn = 64;
    return s;
  }
  static LightFieldView view(int u, int v) {
    LightFieldView w;
    w.u_index = u;
    w.v_index = v;
    w.centroid_m = {(u - 0.5) * 1e-3, (v - 0.5) * 1e-3};
    w.cell_m = {(u - 1) * 2e-3, u * 2e-3, (v - 1) * 2e-3, v * 2e-3};
    w.area_share = 0.25;
    return w;
  }

  // Writes a complete folder of 4 views with a lenslet image and a depth truth; returns
  // the views written.
  std::vector<cv::Mat> write_folder() {
    auto writer = LightFieldFolderWriter::create(dir, {{"camera", "test"}}, {{"seed", 1}});
    EXPECT_TRUE(writer.ok());
    std::vector<cv::Mat> views;
    cv::RNG rng(3);
    for (int v = 0; v < 2; ++v)
      for (int u = 0; u < 2; ++u) {
        cv::Mat image(22, 32, CV_16UC1);
        rng.fill(image, cv::RNG::UNIFORM, 0, 4096);
        EXPECT_TRUE(writer->add_view(image, sidecar(), view(u, v)).ok());
        views.push_back(image);
      }
    cv::Mat raw(40, 66, CV_16UC1, cv::Scalar(100)), white(40, 66, CV_16UC1, cv::Scalar(3000));
    LensletInfo info;
    info.bit_depth = 12;
    info.black_level_dn = 64;
    info.raw_pixel_pitch_um = 2.0;
    EXPECT_TRUE(writer->add_lenslet(raw, white, info).ok());
    cv::Mat depth(22, 32, CV_32F);
    rng.fill(depth, cv::RNG::UNIFORM, 0.5, 3.0);
    depth.at<float>(0, 0) = 0;  // no surface
    EXPECT_TRUE(writer->add_depth_truth(depth).ok());
    EXPECT_TRUE(writer->finish(description()).ok());
    depth_written = depth;
    return views;
  }

  // Rewrites lightfield.json with `edit` applied to it.
  template <class Edit>
  void edit_description(Edit edit) {
    auto text = read_text_file(dir / kLightFieldFileName);
    ASSERT_TRUE(text.ok());
    json j = json::parse(*text);
    edit(j);
    ASSERT_TRUE(write_file_atomically(dir / kLightFieldFileName, j.dump()).ok());
  }

  fs::path dir;
  cv::Mat depth_written;
};

TEST_F(LightFieldFolderTest, EverythingReadsBackExactly) {
  const std::vector<cv::Mat> views = write_folder();
  auto folder = LightFieldFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  const LightFieldDescription& d = folder->description();
  EXPECT_EQ(d.views_u, 2);
  EXPECT_EQ(d.lattice.layout, "hex");
  EXPECT_DOUBLE_EQ(d.lattice.row_pitch, 0.9);
  EXPECT_TRUE(std::isinf(d.optics.focus_distance_m));  // null in the file
  ASSERT_EQ(d.views.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(d.views[k].frame, k);
    EXPECT_DOUBLE_EQ(d.views[k].centroid_m[0], view(k % 2, k / 2).centroid_m[0]);
    auto image = folder->load_view(k);
    ASSERT_TRUE(image.ok());
    EXPECT_EQ(cv::norm(*image, views[static_cast<size_t>(k)], cv::NORM_INF), 0);
  }
  ASSERT_TRUE(d.lenslet.has_value());
  EXPECT_DOUBLE_EQ(d.lenslet->raw_pixel_pitch_um, 2.0);
  auto lenslet = folder->load_lenslet();
  ASSERT_TRUE(lenslet.ok());
  EXPECT_EQ(lenslet->first.at<uint16_t>(5, 5), 100);
  EXPECT_EQ(lenslet->second.at<uint16_t>(5, 5), 3000);
  auto depth = folder->load_depth_truth();
  ASSERT_TRUE(depth.ok()) << depth.error().message;
  EXPECT_EQ(cv::norm(*depth, depth_written, cv::NORM_INF), 0);
  // The folder is a capture folder too: every tool that reads one reads the views.
  EXPECT_EQ(folder->capture().manifest()["kind"], kLightFieldKind);
  EXPECT_TRUE(folder->capture().complete());
}

TEST_F(LightFieldFolderTest, BadDescriptionsGiveSpecificErrors) {
  struct Case {
    void (*edit)(json&);
    ErrorCode code;
    const char* expect;
  };
  const Case cases[] = {
      {[](json& j) { j["version"] = 7; }, ErrorCode::kUnsupportedVersion, "version 7"},
      {[](json& j) { j["views"][1]["u_index"] = 0; }, ErrorCode::kBadManifest, "listed twice"},
      {[](json& j) { j["views"][0]["frame"] = 9; }, ErrorCode::kBadManifest, "names frame 9"},
      {[](json& j) { j["views"][0]["u_index"] = 2; }, ErrorCode::kBadManifest, "u_index = 2"},
      {[](json& j) { j["lattice"]["layout"] = "round"; }, ErrorCode::kBadManifest, "square"},
      {[](json& j) { j["optics"]["f_number"] = -2; }, ErrorCode::kBadManifest, "f_number = -2"},
      {[](json& j) { j["optics"]["lens_to_sensor_mm"] = 7.0; }, ErrorCode::kBadManifest,
       "lens_to_sensor_mm = 7"},
      {[](json& j) { j["lenslet"]["image"] = "../x.png"; }, ErrorCode::kBadManifest,
       "files in the folder"},
      {[](json& j) { j["views"] = json::array(); }, ErrorCode::kBadManifest, "non-empty"},
  };
  for (const Case& c : cases) {
    fs::remove_all(dir);
    write_folder();
    edit_description(c.edit);
    auto folder = LightFieldFolder::open(dir);
    ASSERT_FALSE(folder.ok()) << c.expect;
    EXPECT_EQ(folder.error().code, c.code) << folder.error().message;
    EXPECT_NE(folder.error().message.find(c.expect), std::string::npos) << folder.error().message;
  }
}

TEST_F(LightFieldFolderTest, ACaptureFolderIsNotALightField) {
  auto writer = CaptureFolderWriter::create(dir, "render", json::object(), json::object());
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE(writer->finish().ok());
  auto folder = LightFieldFolder::open(dir);
  ASSERT_FALSE(folder.ok());
  EXPECT_EQ(folder.error().code, ErrorCode::kNotFound);
  EXPECT_NE(folder.error().message.find("not a light field"), std::string::npos);
}

TEST(Pfm, RoundTripsAndRefusesOtherBytes) {
  cv::Mat image(7, 5, CV_32F);
  cv::RNG(9).fill(image, cv::RNG::UNIFORM, -3.0, 3.0);
  image.at<float>(2, 3) = std::numeric_limits<float>::infinity();
  const std::string bytes = encode_pfm(image);
  EXPECT_EQ(bytes.substr(0, 12), "Pf\n5 7\n-1.0\n");
  auto back = decode_pfm(bytes, "test");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(std::memcmp(back->data, image.data, 7 * 5 * 4), 0);
  // The first row of the file is the image's bottom row.
  float first;
  std::memcpy(&first, bytes.data() + 12, 4);
  EXPECT_EQ(first, image.at<float>(6, 0));
  for (const std::string& bad : {std::string("P6\n5 7\n255\n"), bytes.substr(0, bytes.size() - 1),
                                 std::string("Pf\n5 7\n1.0\n") + bytes.substr(12)}) {
    auto result = decode_pfm(bad, "bad.pfm");
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.error().code, ErrorCode::kBadImage);
    EXPECT_NE(result.error().message.find("bad.pfm"), std::string::npos);
  }
}

}  // namespace
}  // namespace camlab::image
