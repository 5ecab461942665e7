// camlabd's captures on the in-process virtual camera against the physics the camera
// spec implies: exposure brackets linear in T (control latency 3 frames in the spec, so
// a frame kept too early would show the previous exposure), a focus stack whose sharpest
// frame is the one the thin lens puts in focus, an aperture series falling as 1/N^2, a
// lens map's grid finding the camera's focus surface.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "capture_checks.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

class ServicePhysics : public SharedDaemonSuite<ServicePhysics> {
 protected:
  static void SetUpTestSuite() {
    start_shared_daemon("physics", [](const fs::path& dir) {
      return Launch{{"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
                     (dir / "scene.json").string()},
                    {}};
    });
  }
};

TEST_F(ServicePhysics, BracketSignalIsProportionalToExposure) {
  check_bracket_is_linear(*daemon_, camera_);
}

TEST_F(ServicePhysics, FocusStackIsSharpestWhereTheThinLensIsInFocus) {
  // The edge is at 1.288 m: 1/f = 1/z_o + 1/z_i gives z_i = 8.05 mm, focus position
  // (z_i - f) / 0.001 mm = 50.
  const double f_mm = 8.0, z_o_mm = 1288.0;
  const double truth_position = (1.0 / (1.0 / f_mm - 1.0 / z_o_mm) - f_mm) / 0.001;
  ASSERT_NEAR(truth_position, 50.0, 0.1);
  auto r = daemon_->post(camera_ + "/captures",
                         {{"kind", "focus_stack"},
                          {"start", 20},
                          {"stop", 80},
                          {"step", 10},
                          {"controls", {{"iris_absolute", 7}, {"exposure_time_absolute", 10}}}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t id = r.json()["id"];
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  double best = -1;
  int best_position = -1;
  std::set<int> positions;
  for (int i = 0; i < 7; ++i) {
    const DownloadedFrame frame = download_frame(*daemon_, id, i);
    const int position = frame.sidecar["settings"]["focus_position"];
    positions.insert(position);
    const double s = sharpness(frame.image);
    if (s > best) {
      best = s;
      best_position = position;
    }
  }
  EXPECT_EQ(positions, (std::set<int>{20, 30, 40, 50, 60, 70, 80}));
  EXPECT_EQ(best_position, static_cast<int>(std::lround(truth_position)));
}

TEST_F(ServicePhysics, ApertureSeriesSignalFallsAsOneOverNSquared) {
  auto r = daemon_->post(camera_ + "/captures", {{"kind", "aperture_series"},
                                                 {"f_numbers", {2.8, 4, 5.6, 8}},
                                                 {"controls", {{"exposure_time_absolute", 80}}}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t id = r.json()["id"];
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  std::vector<double> signal_n2;
  for (int i = 0; i < 4; ++i) {
    const DownloadedFrame frame = download_frame(*daemon_, id, i);
    const double n = frame.sidecar["settings"]["f_number"];
    bool clipped = true;
    const double signal = mean_above_black(frame, &clipped);
    EXPECT_FALSE(clipped) << "f/" << n;
    EXPECT_GT(signal, 40.0) << "f/" << n;
    signal_n2.push_back(signal * n * n);
  }
  for (int i = 1; i < 4; ++i) EXPECT_NEAR(signal_n2[i] / signal_n2[0], 1.0, 0.02) << "frame " << i;
}

// A lens-map capture (iris stops x focus positions) through camlabd's camera worker on the
// example camera whose focus surface is tilted 0.4 deg right, -0.25 deg down and curved
// -15 um at the corner, of the lens-map chart; then the lensmap analysis job on it finds
// that surface at each stop.
TEST(ServiceLensMap, ALensMapCaptureAndItsAnalysisFindTheCamerasFocusSurface) {
  const fs::path dir = fresh_test_dir("service_lens_map");
  Daemon daemon;
  ASSERT_TRUE(daemon.start(
      dir, {"--no-scan", "--camera-spec",
            CAMLAB_SOURCE_DIR "/mock_device/examples/camera_640x480_field_focus.json", "--scene",
            CAMLAB_SOURCE_DIR "/mock_device/examples/scene_lensmap_chart.json"}))
      << daemon.log();
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  // A focus stack's fields with an aperture series': refused fields are named.
  auto bad = daemon.post(camera + "/captures", {{"kind", "lens_map"}, {"start", 15}});
  EXPECT_EQ(bad.status, 400) << bad.body;
  auto r = daemon.post(camera + "/captures", {{"kind", "lens_map"},
                                              {"f_numbers", {1.4, 2.8}},
                                              {"start", 15},
                                              {"stop", 113},
                                              {"step", 7},
                                              {"base_exposure_us", 2000}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t capture_id = r.json()["id"];
  const json capture = daemon.wait_finished(capture_id, std::chrono::seconds(120));
  ASSERT_EQ(capture["state"], "succeeded") << capture.dump();
  // Each frame by its step (a frame the writer had no room for is taken again later, so
  // the folder's order need not be the plan's): the focus stepped inside each stop, and
  // the exposure held across the stops, f/2.8's time four times f/1.4's.
  const std::string frames_url = "/v1/jobs/" + std::to_string(capture_id) + "/frames";
  ASSERT_EQ(daemon.get(frames_url).json()["frames"].size(), 30u);
  std::set<int> steps;
  for (int i = 0; i < 30; ++i) {
    const json meta = daemon.get(frames_url + "/" + std::to_string(i) + "/meta").json();
    const int step = meta["labels"]["step_index"].get<int>();
    steps.insert(step);
    const json& settings = meta["settings"];
    EXPECT_EQ(settings["focus_position"], 15 + 7 * (step % 15)) << step;
    EXPECT_NEAR(settings["f_number"].get<double>(), step < 15 ? 1.4 : 2.8, 1e-9) << step;
    EXPECT_DOUBLE_EQ(settings["exposure_us"].get<double>(), step < 15 ? 2000 : 8000) << step;
  }
  EXPECT_EQ(steps.size(), 30u) << "every step once";

  auto analysis = daemon.post("/v1/analyses", {{"kind", "lensmap"}, {"job", capture_id}});
  ASSERT_EQ(analysis.status, 202) << analysis.body;
  const json job = daemon.wait_finished(analysis.json()["id"], std::chrono::seconds(120));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json& surfaces = job["result"]["report"]["surfaces"];
  ASSERT_EQ(surfaces.size(), 2u) << job.dump().substr(0, 2000);
  // Its plots (the surface and the through-focus curves per stop) are the job's to fetch.
  auto plots = daemon.get("/v1/jobs/" + std::to_string(job["id"].get<int64_t>()) + "/plots");
  ASSERT_EQ(plots.status, 200) << plots.body;
  EXPECT_NE(plots.body.find("lensmap_surface_f1_4.png"), std::string::npos) << plots.body;
  EXPECT_NE(plots.body.find("lensmap_through_focus_f2_8.png"), std::string::npos) << plots.body;
  for (const json& s : surfaces) {
    const json& at_sensor = s["at_sensor"];
    std::printf("f/%g: tilt %.4f %.4f deg, curvature %.2f um, astigmatism %.2f +- %.2f um\n",
                s["f_number"].get<double>(), at_sensor["tilt_x_deg"].get<double>(),
                at_sensor["tilt_y_deg"].get<double>(), at_sensor["curvature_um"].get<double>(),
                at_sensor["astigmatism_um"].get<double>(),
                at_sensor["standard_errors"]["astigmatism_um"].get<double>());
    EXPECT_NEAR(at_sensor["tilt_x_deg"].get<double>(), 0.4, 0.05);
    EXPECT_NEAR(at_sensor["tilt_y_deg"].get<double>(), -0.25, 0.05);
    EXPECT_NEAR(at_sensor["curvature_um"].get<double>(), -15, 1.5);
  }
  daemon.stop(SIGTERM);
  fs::remove_all(dir);
}

}  // namespace
