// camlabd's captures on the in-process virtual camera against the physics the camera
// spec implies: exposure brackets linear in T (control latency 3 frames in the spec, so
// a frame kept too early would show the previous exposure), a focus stack whose sharpest
// frame is the one the thin lens puts in focus, an aperture series falling as 1/N^2.
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

}  // namespace
