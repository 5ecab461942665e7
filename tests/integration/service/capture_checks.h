// Frame downloads and the measurements the physics tests make on them (mean signal above
// black, sharpness), shared by the in-process and the `vcam run` suites.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "daemon_harness.h"

namespace camlab::testing {

struct DownloadedFrame {
  cv::Mat image;  // raw DN
  nlohmann::json sidecar;
};

inline DownloadedFrame download_frame(const Daemon& daemon, int64_t job, int index) {
  DownloadedFrame frame;
  const std::string base = "/v1/jobs/" + std::to_string(job) + "/frames/" + std::to_string(index);
  auto png = daemon.get(base);
  EXPECT_EQ(png.status, 200) << base;
  EXPECT_EQ(png.headers["content-type"], "image/png");
  frame.image =
      cv::imdecode(std::vector<uchar>(png.body.begin(), png.body.end()), cv::IMREAD_UNCHANGED);
  auto meta = daemon.get(base + "/meta");
  EXPECT_EQ(meta.status, 200) << base;
  frame.sidecar = meta.json();
  return frame;
}

// Mean DN above the sidecar's black level over the central half of the frame, and
// whether any pixel there is clipped.
inline double mean_above_black(const DownloadedFrame& frame, bool* clipped = nullptr) {
  const cv::Rect centre(frame.image.cols / 4, frame.image.rows / 4, frame.image.cols / 2,
                        frame.image.rows / 2);
  double max_value = 0;
  cv::minMaxLoc(frame.image(centre), nullptr, &max_value);
  const int bit_depth = frame.sidecar.value("bit_depth", 8);
  if (clipped) *clipped = max_value >= (1 << bit_depth) - 1;
  return cv::mean(frame.image(centre))[0] - frame.sidecar.value("black_level_dn", 0);
}

// Energy of the Laplacian: larger when sharper.
inline double sharpness(const cv::Mat& image) {
  cv::Mat f, lap;
  image.convertTo(f, CV_64F);
  cv::Laplacian(f, lap, CV_64F, 3);
  cv::Scalar mean, stddev;
  cv::meanStdDev(lap, mean, stddev);
  return stddev[0] * stddev[0];
}

// Runs a 1, 2, 4, 8 ms bracket on `camera_path` (with `controls` fixed) and checks the
// mean signal above black is proportional to exposure within 2%, with nothing clipped.
// Returns the worst relative deviation of signal/exposure from the 1 ms frame's (NaN when
// the job failed), and checks the control latency used when `latency_frames` >= 0.
inline double check_bracket_is_linear(const Daemon& daemon, const std::string& camera_path,
                                      const nlohmann::json& controls = {{"iris_absolute", 5}},
                                      int latency_frames = 3) {
  auto r = daemon.post(
      camera_path + "/captures",
      {{"kind", "bracket"}, {"exposures_us", {1000, 2000, 4000, 8000}}, {"controls", controls}});
  EXPECT_EQ(r.status, 202) << r.body;
  if (r.status != 202) return std::nan("");
  const int64_t id = r.json()["id"];
  const nlohmann::json job = daemon.wait_finished(id);
  EXPECT_EQ(job["state"], "succeeded") << job.dump();
  if (job["state"] != "succeeded") return std::nan("");
  if (latency_frames >= 0) {
    EXPECT_EQ(job["result"]["control_latency_frames"], latency_frames) << job.dump();
  }
  std::vector<double> per_us;
  for (int i = 0; i < 4; ++i) {
    const DownloadedFrame frame = download_frame(daemon, id, i);
    EXPECT_FALSE(frame.image.empty());
    if (frame.image.empty()) return std::nan("");
    const double exposure_us = frame.sidecar["settings"]["exposure_us"].get<double>();
    EXPECT_DOUBLE_EQ(exposure_us, 1000.0 * (1 << i)) << frame.sidecar.dump();
    bool clipped = true;
    const double signal = mean_above_black(frame, &clipped);
    EXPECT_FALSE(clipped) << "frame " << i;
    EXPECT_GT(signal, 5.0) << "frame " << i;
    per_us.push_back(signal / exposure_us);
  }
  double worst = 0;
  for (int i = 1; i < 4; ++i) {
    EXPECT_NEAR(per_us[i] / per_us[0], 1.0, 0.02)
        << "signal/exposure of " << (1 << i) << " ms vs 1 ms";
    worst = std::max(worst, std::abs(per_us[i] / per_us[0] - 1.0));
  }
  return worst;
}

// One daemon shared by a suite's tests (they only read its cameras and add jobs), on the
// test camera and scene (write_test_specs). Suite is the derived fixture (CRTP), so each
// suite owns its daemon. start_shared_daemon() is called from the suite's SetUpTestSuite
// with `make_args(dir)` giving the daemon's arguments and launch prefix.
template <class Suite>
class SharedDaemonSuite : public ::testing::Test {
 protected:
  struct Launch {
    std::vector<std::string> args;
    std::vector<std::string> prefix;
  };
  template <class MakeLaunch>
  static void start_shared_daemon(const std::string& name, MakeLaunch make_launch) {
    dir_ = new fs::path(fresh_test_dir(name));
    write_test_specs(*dir_);
    daemon_ = new Daemon();
    const Launch launch = make_launch(*dir_);
    started_ = daemon_->start(*dir_, launch.args, launch.prefix);
    if (started_) camera_ = "/v1/cameras/" + url_segment(daemon_->camera_id());
  }
  static void TearDownTestSuite() {
    if (daemon_) daemon_->stop(SIGTERM);
    delete daemon_;
    daemon_ = nullptr;
    if (dir_) fs::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override { ASSERT_TRUE(started_) << (daemon_ ? daemon_->log() : ""); }

  static inline fs::path* dir_ = nullptr;
  static inline Daemon* daemon_ = nullptr;
  static inline bool started_ = false;
  static inline std::string camera_;
};

}  // namespace camlab::testing
