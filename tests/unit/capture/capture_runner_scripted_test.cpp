// The runner's frame accounting on a scripted sensor whose truth is in every pixel:
// frames consumed against the minimum for exact latencies, and the kept frames' settings
// against the truth with uncertain latencies, drops, flagged frames, no timestamps, a
// failing camera and cancel.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "capture/capture_runner.h"
#include "image/capture_folder.h"
#include "scripted_camera.h"
#include "virtual_camera.h"

namespace camlab::capture {
namespace {

using nlohmann::json;

struct Outcome {
  CaptureSummary summary;
  std::vector<image::FrameSidecar> sidecars;
  bool complete = false;
};

// Runs a bracket of exposure_time_absolute 10, 20, ... 90 (x 100 us) and checks every
// written frame against the truth its pixels carry.
Outcome run_bracket(testing::ScriptedCamera& camera, const CaptureOptions& options, int repeats = 1,
                    CaptureObserver* observer = nullptr) {
  json request = {{"kind", "bracket"}, {"exposures_us", json::array()}, {"repeats", repeats}};
  for (int i = 1; i <= 9; ++i) request["exposures_us"].push_back(1000 * i);
  auto plan = plan_capture(request, *camera.controls(), *camera.formats());
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  testing::ScratchDir dir("scripted");
  auto summary = run_capture(camera, *plan, dir / "capture", options, observer);
  EXPECT_TRUE(summary.ok()) << summary.error().message;
  Outcome out;
  out.summary = *summary;
  auto folder = image::CaptureFolder::open(dir / "capture");
  EXPECT_TRUE(folder.ok()) << folder.error().message;
  out.complete = folder->complete();
  int discarded_in_sidecars = 0;
  for (int i = 0; i < static_cast<int>(folder->frames().size()); ++i) {
    auto image = folder->load_image(i);
    auto sidecar = folder->load_sidecar(i);
    EXPECT_TRUE(image.ok() && sidecar.ok());
    const int64_t exposure = sidecar->settings["exposure_time_absolute"].get<int64_t>();
    double min = 0, max = 0;
    cv::minMaxLoc(*image, &min, &max);
    EXPECT_EQ(min, static_cast<double>(exposure))
        << "frame " << sidecar->sequence << " is not the exposure it claims";
    EXPECT_EQ(max, static_cast<double>(exposure));
    EXPECT_EQ(sidecar->settings["exposure_us"], 100.0 * exposure);
    EXPECT_EQ(sidecar->settings["requested"]["exposure_us"], 100.0 * exposure);
    EXPECT_EQ(sidecar->labels["step_index"].get<int>(), exposure / 10 - 1);
    discarded_in_sidecars += sidecar->frames_discarded;
    out.sidecars.push_back(*sidecar);
  }
  const CaptureSummary& s = out.summary;
  EXPECT_EQ(s.frames_consumed, s.frames_kept + s.frames_discarded + s.frames_dropped);
  if (out.complete) {
    EXPECT_EQ(discarded_in_sidecars, s.frames_consumed - s.frames_kept)
        << "the sidecars account for every frame";
    EXPECT_EQ(camera.next_sequence() >= static_cast<uint64_t>(s.frames_consumed), true);
  }
  return out;
}

class ScriptedLatency : public ::testing::TestWithParam<int> {};

TEST_P(ScriptedLatency, NineStepBracketConsumesNinePlusLatencyFrames) {
  const int latency = GetParam();
  testing::ScriptedCamera camera(latency, 0);
  CaptureOptions options;
  options.control_latency_frames = latency;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_EQ(out.summary.frames_kept, 9);
  EXPECT_EQ(out.summary.frames_minimum, 9 + latency);
  EXPECT_EQ(out.summary.frames_consumed, 9 + latency);
  EXPECT_EQ(out.sidecars.front().frames_discarded, latency);
  EXPECT_EQ(out.sidecars.back().frames_discarded, 0);
}

TEST_P(ScriptedLatency, RepeatsAdvanceTheStepsByTheRepeatCount) {
  const int latency = GetParam();
  testing::ScriptedCamera camera(latency, 0);
  CaptureOptions options;
  options.control_latency_frames = latency;
  Outcome out = run_bracket(camera, options, 2);
  EXPECT_EQ(out.summary.frames_kept, 18);
  EXPECT_EQ(out.summary.frames_consumed, 18 + latency);
  EXPECT_EQ(out.sidecars[3].labels["repeat"], 1);
}

INSTANTIATE_TEST_SUITE_P(Latency, ScriptedLatency, ::testing::Values(0, 1, 3));

TEST(ScriptedCapture, AFrameAlreadyExposingCostsOneFramePerStepNotCorrectness) {
  testing::ScriptedCamera camera(2, 1);
  CaptureOptions options;
  options.control_latency_frames = 2;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_LE(out.summary.frames_consumed, 2 * 9 + 2);
}

TEST(ScriptedCapture, AnUncertainLatencyWaitsLongerAndStaysRight) {
  // The sensor's latency is 1; the runner only knows it is 0..3.
  testing::ScriptedCamera camera(1, 0);
  CaptureOptions options;
  options.control_latency_frames = 3;
  options.control_latency_min_frames = 0;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_GT(out.summary.frames_consumed, 9 + 3);
}

TEST(ScriptedCapture, DroppedAndFlaggedFramesAreRetakenWithTheirSettings) {
  testing::ScriptedCamera camera(3, 0);
  camera.drop_sequences = {4, 5, 9};  // frames steps 1, 2 and 6 needed
  camera.error_sequences = {7};       // step 4's
  CaptureOptions options;
  options.control_latency_frames = 3;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_EQ(out.summary.frames_kept, 9);
  EXPECT_EQ(out.summary.frames_dropped, 3);
  EXPECT_GE(out.summary.steps_retaken, 3);
  std::set<int> steps;
  for (const auto& s : out.sidecars) steps.insert(s.labels["step_index"].get<int>());
  EXPECT_EQ(steps.size(), 9u) << "every step once";
}

TEST(ScriptedCapture, WithoutMonotonicTimestampsTheBufferBoundKeepsItRight) {
  testing::ScriptedCamera camera(2, 1);
  camera.clock = "unknown";
  CaptureOptions options;
  options.control_latency_frames = 2;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_EQ(out.summary.frames_kept, 9);
}

TEST(ScriptedCapture, ACameraFailingMidRunKeepsItsFramesAndReportsTheFailure) {
  testing::ScriptedCamera camera(1, 0);
  camera.fail_set_after = 5;  // auto_exposure, then steps 0..3 succeed
  CaptureOptions options;
  options.control_latency_frames = 1;
  Outcome out = run_bracket(camera, options);
  ASSERT_TRUE(out.summary.failure.has_value());
  EXPECT_EQ(out.summary.failure->code, "no_device");
  EXPECT_FALSE(out.complete);
  EXPECT_GE(out.summary.frames_kept, 3);
  EXPECT_LT(out.summary.frames_kept, 9);
  EXPECT_EQ(out.sidecars.size(), static_cast<size_t>(out.summary.frames_kept));
  EXPECT_TRUE(out.summary.restore_error.has_value());
}

TEST(ScriptedCapture, ControlsAreRestoredIncludingTheAutoModeAManualValueSwitchedOff) {
  testing::ScriptedCamera camera(1, 0);
  ASSERT_EQ(*camera.get_control("auto_exposure"), 3);
  CaptureOptions options;
  options.control_latency_frames = 1;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_FALSE(out.summary.restore_error.has_value());
  EXPECT_EQ(*camera.get_control("exposure_time_absolute"), 10);
  EXPECT_EQ(*camera.get_control("auto_exposure"), 3);
}

class CountingObserver : public CaptureObserver {
 public:
  void on_frame(const image::CaptureFrameEntry&, const image::FrameSidecar&,
                const CaptureProgress& progress) override {
    ++calls;
    EXPECT_EQ(progress.frames_kept, calls);
    EXPECT_EQ(progress.frames_total, 9);
  }
  int calls = 0;
};

TEST(ScriptedCapture, CancelStopsBetweenFramesAndRestores) {
  testing::ScriptedCamera camera(1, 0);
  std::atomic<bool> cancel{false};
  camera.on_dequeue = [&](uint64_t sequence) {
    if (sequence == 3) cancel = true;
  };
  CountingObserver observer;
  CaptureOptions options;
  options.control_latency_frames = 1;
  options.cancel = &cancel;
  Outcome out = run_bracket(camera, options, 1, &observer);
  EXPECT_TRUE(out.summary.cancelled);
  EXPECT_FALSE(out.complete);
  EXPECT_EQ(out.summary.frames_kept, 3) << "frames 1, 2, 3; frame 3 was in hand when cancel came";
  EXPECT_EQ(observer.calls, out.summary.frames_kept) << "every written frame was reported";
  EXPECT_EQ(*camera.get_control("auto_exposure"), 3);
  EXPECT_EQ(*camera.get_control("exposure_time_absolute"), 10);
}

// A camera that reports each frame's exposure: frames are kept by their own report, so a
// latency given wrong (1 frame for a sensor's 3) still keeps only frames whose pixels are
// the exposure they claim (run_bracket checks each against the truth in its pixels).
TEST(ScriptedReport, FramesAreKeptByTheirReportWhenTheLatencyGivenIsWrong) {
  testing::ScriptedCamera camera(3, 1);
  camera.report_exposure = true;
  CaptureOptions options;
  options.control_latency_frames = 1;
  Outcome out = run_bracket(camera, options);
  EXPECT_TRUE(out.complete);
  EXPECT_EQ(out.summary.frames_kept, 9);
  for (const auto& sidecar : out.sidecars) {
    EXPECT_EQ(sidecar.settings["in_effect_by"], "frame_report");
    EXPECT_EQ(sidecar.settings["reported"]["exposure_us"], sidecar.settings["exposure_us"]);
  }
}

// The same camera without reports and the same wrong latency: the latency rule keeps
// frames too early (what the report rule above prevents), which the truth shows.
TEST(ScriptedReport, WithoutReportsAWrongLatencyKeepsWrongFrames) {
  testing::ScriptedCamera camera(3, 1);
  CaptureOptions options;
  options.control_latency_frames = 1;
  json request = {{"kind", "bracket"}, {"exposures_us", {1000, 2000, 3000, 4000}}};
  auto plan = plan_capture(request, *camera.controls(), *camera.formats());
  ASSERT_TRUE(plan.ok());
  testing::ScratchDir dir("scripted_no_report");
  auto summary = run_capture(camera, *plan, dir / "capture", options, nullptr);
  ASSERT_TRUE(summary.ok());
  auto folder = image::CaptureFolder::open(dir / "capture");
  ASSERT_TRUE(folder.ok());
  int wrong = 0;
  for (int i = 0; i < static_cast<int>(folder->frames().size()); ++i) {
    double min = 0, max = 0;
    cv::minMaxLoc(*folder->load_image(i), &min, &max);
    wrong += min != folder->load_sidecar(i)->settings["exposure_time_absolute"].get<double>();
  }
  EXPECT_GT(wrong, 0);
}

}  // namespace
}  // namespace camlab::capture
