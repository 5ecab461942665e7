// The README's calibration set, all 40 views of the example scene (14x10 board through the
// OPENCV8 wide lens of mock_device/examples), calibrated from its images with
// LENSMODEL_OPENCV8: the report's horizontal and vertical FOV must be within 0.1 deg of
// the truth's, computed here by unprojecting the truth model's edge midpoints with mrcal's
// own mrcal_unproject (not through camlab's lens_model.cpp). The frames are rendered in
// process with 4 area samples a pixel and no lens sampling (the lens's blur is under a
// quarter pixel here) to keep the test near 20 s on 2 cores; the corners are those of the
// default detector, and nothing but camlab's own lines may reach stderr meanwhile.
#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibrate.h"
#include "calib/mrcal_api.h"
#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

double angle_deg(const mrcal_point3_t& a, const mrcal_point3_t& b) {
  const double cx = a.y * b.z - a.z * b.y, cy = a.z * b.x - a.x * b.z, cz = a.x * b.y - a.y * b.x;
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), a.x * b.x + a.y * b.y + a.z * b.z) *
         180 / M_PI;
}

TEST(CalibFovExample, FortyViewsOpencv8GiveTheTruthsHorizontalAndVerticalFov) {
  const fs::path examples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
  auto camera = mock::load_camera_spec(examples / "camera_wide_1280x800.json");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  auto scene = mock::load_scene_spec(examples / "scene_chessboard_calibration.json");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto renderer = mock::Renderer::create(std::move(*camera), std::move(*scene));
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;

  const fs::path dir =
      fs::temp_directory_path() / ("camlab_fov_example_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string truth_text;
  for (int view = 0; view < 40; ++view) {
    mock::RenderOptions options;
    options.frame_number = view;
    options.pixel_samples = 4;
    options.aperture_samples = 0;
    auto frame = renderer->render(renderer->default_settings(), view, options);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    char name[32];
    std::snprintf(name, sizeof name, "view_%02d.png", view);
    ASSERT_TRUE(cv::imwrite((dir / name).string(), frame->image));
    if (view == 0) truth_text = frame->truth["cameramodel"].get<std::string>();
  }

  CalibrateOptions o;
  o.images_dir = dir;
  o.board = {14, 10, 0.04};
  o.model = "LENSMODEL_OPENCV8";
  // The FOV is checked, not the repeatability (calib/repeatability.h: its 2 + 24 re-solves
  // of 40 views took this test from 20 s to 60-90 s; repeatability_test.cpp checks them).
  o.repeatability = false;
  // Nothing but camlab's own lines may reach stderr: mrcal prints each outlier-rejection
  // round there (library_stderr.h routes it into the log). fd 2 goes to a file meanwhile.
  const fs::path err_path = dir / "stderr.txt";
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  const int err_fd = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ASSERT_GE(saved, 0);
  ASSERT_GE(err_fd, 0);
  ::dup2(err_fd, STDERR_FILENO);
  ::close(err_fd);
  auto run = calibrate(o);
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::ifstream err_in(err_path);
  for (std::string line; std::getline(err_in, line);)
    EXPECT_EQ(line.rfind("camlab ", 0), 0u) << "not camlab's own line on stderr: " << line;
  fs::remove_all(dir);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->data.views.size(), 35u);

  mrcal_cameramodel_t* truth = mrcal_read_cameramodel_string(truth_text.c_str(), 0);
  ASSERT_NE(truth, nullptr);
  const double w = truth->imagersize[0], h = truth->imagersize[1];
  const mrcal_point2_t q[4] = {{{-0.5, (h - 1) / 2}},
                               {{w - 0.5, (h - 1) / 2}},
                               {{(w - 1) / 2, -0.5}},
                               {{(w - 1) / 2, h - 0.5}}};
  mrcal_point3_t v[4];
  ASSERT_TRUE(mrcal_unproject(v, q, 4, &truth->lensmodel, truth->intrinsics));
  mrcal_free_cameramodel(&truth);
  const double truth_h = angle_deg(v[0], v[1]), truth_v = angle_deg(v[2], v[3]);

  const auto& fov = run->report.fov;
  ASSERT_TRUE(fov.horizontal_deg && fov.vertical_deg);
  std::printf("%zu views: FOV %.3f x %.3f deg (truth %.3f x %.3f), diagonal %s\n",
              run->data.views.size(), *fov.horizontal_deg, *fov.vertical_deg, truth_h, truth_v,
              fov.diagonal_deg ? std::to_string(*fov.diagonal_deg).c_str() : "undefined");
  EXPECT_NEAR(*fov.horizontal_deg, truth_h, 0.1);
  EXPECT_NEAR(*fov.vertical_deg, truth_v, 0.1);
  const auto& j = run->report_json["fov_deg"];
  EXPECT_NEAR(j["horizontal"].get<double>(), truth_h, 0.1);
  EXPECT_NEAR(j["vertical"].get<double>(), truth_v, 0.1);
}

}  // namespace
}  // namespace camlab::calib
