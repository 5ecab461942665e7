// Capture plans against the virtual camera's real controls and formats: every kind, the
// unit conversions, and the errors a client gets (code and a message naming the range).
#include "capture/capture_plan.h"

#include <gtest/gtest.h>

#include "virtual_camera.h"

namespace camlab::capture {
namespace {

using nlohmann::json;

class CapturePlanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    vcam_ = testing::open_virtual_camera(testing::capture_camera_json(0),
                                         mock::testing::uniform_scene_json(1.0, 0.5), false);
    auto controls = vcam_.camera->controls();
    auto formats = vcam_.camera->formats();
    ASSERT_TRUE(controls.ok() && formats.ok());
    controls_ = *controls;
    formats_ = *formats;
  }

  Result<CapturePlan> plan(const json& request, bool with_traits = true) {
    return plan_capture(request, controls_, formats_, with_traits ? vcam_.traits : CameraTraits{});
  }

  // Expects an error with this code whose message contains `text`.
  void expect_error(const json& request, const std::string& code, const std::string& text = "") {
    auto p = plan(request);
    ASSERT_FALSE(p.ok()) << request.dump();
    EXPECT_EQ(p.error().code, code) << request.dump() << ": " << p.error().message;
    EXPECT_NE(p.error().message.find(text), std::string::npos) << p.error().message;
  }

  testing::VirtualCamera vcam_;
  std::vector<device::ControlInfo> controls_;
  std::vector<device::PixelFormatInfo> formats_;
};

TEST_F(CapturePlanTest, BracketOfExposuresBecomesHundredMicrosecondUnitsWithManualExposure) {
  auto p = plan({{"kind", "bracket"},
                 {"exposures_us", {1000, 2000, 4000, 8000}},
                 {"gain", 200},
                 {"repeats", 2}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->kind, "bracket");
  ASSERT_EQ(p->steps.size(), 4u);
  EXPECT_EQ(p->steps[2].controls.at("exposure_time_absolute"), 40);
  EXPECT_EQ(p->steps[2].requested["exposure_us"], 4000.0);
  EXPECT_EQ(p->steps[3].labels["step_index"], 3);
  EXPECT_EQ(p->fixed_controls.at("auto_exposure"), 1) << "manual";
  EXPECT_EQ(p->fixed_controls.at("gain"), 200);
  EXPECT_EQ(p->repeats, 2);
  EXPECT_EQ(p->total_frames(), 8);
  // No format asked: the deepest greyscale format at full size.
  EXPECT_EQ(p->format.fourcc, "Y16 ");
  EXPECT_EQ(p->format.width, 64u);
  EXPECT_EQ(p->format.height, 48u);
  EXPECT_EQ(p->request["steps"].size(), 4u);
}

TEST_F(CapturePlanTest, EvBracketRoundsOntoTheExposureGrid) {
  auto p =
      plan({{"kind", "bracket"}, {"base_exposure_us", 2000}, {"ev_steps", {-1, 0, 1, 1.0 / 3}}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 4u);
  EXPECT_EQ(p->steps[0].controls.at("exposure_time_absolute"), 10);
  EXPECT_EQ(p->steps[2].controls.at("exposure_time_absolute"), 40);
  EXPECT_EQ(p->steps[3].controls.at("exposure_time_absolute"), 25) << "2520 us rounds to 2500";
  EXPECT_NEAR(p->steps[3].requested["exposure_us"].get<double>(), 2519.8, 0.1);
}

TEST_F(CapturePlanTest, ExposuresOffTheGridOrOutOfRangeNameTheRangeInMicroseconds) {
  const std::string range = "100..10000 us in steps of 100 us";
  expect_error({{"kind", "bracket"}, {"exposures_us", {1000, 150}}}, "out_of_range", range);
  expect_error({{"kind", "bracket"}, {"exposures_us", {20000}}}, "out_of_range", range);
  expect_error({{"kind", "bracket"}, {"exposures_us", {50}}}, "out_of_range",
               "exposures_us[0] = 50 us");
  expect_error({{"kind", "bracket"}, {"base_exposure_us", 100}, {"ev_steps", {-2}}}, "out_of_range",
               range);
  expect_error({{"kind", "single"}, {"exposure_us", 0}}, "out_of_range", range);
  expect_error({{"kind", "bracket"}, {"exposures_us", {1000}}, {"gain", 5000}}, "out_of_range",
               "[100, 1600]");
}

TEST_F(CapturePlanTest, FocusStackFromARangeTurnsAutofocusOffAndKnowsTheDistances) {
  auto p = plan({{"kind", "focus_stack"}, {"start", 0}, {"stop", 100}, {"step", 25}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 5u);
  EXPECT_EQ(p->steps[4].controls.at("focus_absolute"), 100);
  EXPECT_EQ(p->fixed_controls.at("focus_automatic_continuous"), 0);
  EXPECT_TRUE(p->steps[0].requested["focus_distance_m"].is_null())
      << "position 0 focuses at infinity";
  // s = f (f + p e) / (p e) = 8 x 8.1 / 0.1 mm at p = 100.
  EXPECT_NEAR(p->steps[4].requested["focus_distance_m"].get<double>(), 0.648, 1e-9);
  auto descending = plan({{"kind", "focus_stack"}, {"start", 100}, {"stop", 0}, {"step", -40}});
  ASSERT_TRUE(descending.ok()) << descending.error().message;
  EXPECT_EQ(descending->steps.size(), 3u) << "100, 60, 20";
}

TEST_F(CapturePlanTest, FocusStackErrors) {
  expect_error({{"kind", "focus_stack"}, {"positions", {10, 5000}}}, "out_of_range", "[0, 2000]");
  expect_error({{"kind", "focus_stack"}, {"start", 0}, {"stop", 100}, {"step", 0}},
               "invalid_request");
  expect_error({{"kind", "focus_stack"}, {"start", 0}, {"stop", 100}, {"step", -5}},
               "invalid_request");
  expect_error({{"kind", "focus_stack"}, {"start", 0}, {"stop", 2000}, {"step", 1}},
               "invalid_request", "at most 1000");
  expect_error({{"kind", "focus_stack"}, {"start", 0}, {"stop", 100}}, "invalid_request",
               "start, stop and step");
  expect_error({{"kind", "focus_stack"}, {"positions", {1.5}}}, "invalid_request", "whole number");
}

TEST_F(CapturePlanTest, ApertureSeriesMatchesFNumbersToIrisStops) {
  auto p = plan(
      {{"kind", "aperture_series"}, {"f_numbers", {2, 2.8, 5.6, 5.66}}, {"exposure_us", 2000}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 4u);
  EXPECT_EQ(p->steps[0].controls.at("iris_absolute"), 6);
  EXPECT_EQ(p->steps[1].controls.at("iris_absolute"), 5);
  EXPECT_EQ(p->steps[2].controls.at("iris_absolute"), 3);
  EXPECT_EQ(p->steps[3].controls.at("iris_absolute"), 3) << "f/5.66 is the engraved f/5.6";
  EXPECT_EQ(p->fixed_controls.at("exposure_time_absolute"), 20);
  EXPECT_EQ(p->fixed_controls.at("auto_exposure"), 1);
  expect_error({{"kind", "aperture_series"}, {"f_numbers", {3}}}, "out_of_range",
               "f/16, f/11, f/8, f/5.6");
  auto no_table = plan({{"kind", "aperture_series"}, {"f_numbers", {2}}}, false);
  ASSERT_FALSE(no_table.ok());
  EXPECT_EQ(no_table.error().code, "unsupported");
  auto by_position = plan({{"kind", "aperture_series"}, {"iris_positions", {0, 7}}});
  ASSERT_TRUE(by_position.ok()) << by_position.error().message;
  EXPECT_EQ(by_position->steps[1].requested["f_number"], 1.4);
  expect_error({{"kind", "aperture_series"}, {"iris_positions", {9}}}, "out_of_range", "[0, 7]");
}

TEST_F(CapturePlanTest, LensMapIsEveryStopTimesEveryFocusPositionFocusInside) {
  auto p = plan({{"kind", "lens_map"},
                 {"f_numbers", {2, 5.6}},
                 {"start", 0},
                 {"stop", 100},
                 {"step", 50},
                 {"exposure_us", 2000}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 6u);
  const int64_t iris[6] = {6, 6, 6, 3, 3, 3}, focus[6] = {0, 50, 100, 0, 50, 100};
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(p->steps[i].controls.at("iris_absolute"), iris[i]) << i;
    EXPECT_EQ(p->steps[i].controls.at("focus_absolute"), focus[i]) << i;
    EXPECT_EQ(p->steps[i].requested["focus_position"], focus[i]) << i;
    EXPECT_EQ(p->steps[i].labels["step_index"], static_cast<int>(i));
  }
  EXPECT_EQ(p->steps[4].requested["f_number"], 5.6);
  EXPECT_NEAR(p->steps[5].requested["focus_distance_m"].get<double>(), 0.648, 1e-9);
  EXPECT_EQ(p->fixed_controls.at("focus_automatic_continuous"), 0);
  EXPECT_EQ(p->fixed_controls.at("auto_exposure"), 1);
  // Each half is checked as its own kind checks it, and both halves are needed.
  expect_error({{"kind", "lens_map"}, {"f_numbers", {3}}, {"positions", {0}}}, "out_of_range",
               "f/16, f/11");
  expect_error({{"kind", "lens_map"}, {"f_numbers", {2}}, {"positions", {5000}}}, "out_of_range",
               "[0, 2000]");
  expect_error({{"kind", "lens_map"}, {"positions", {0, 10}}}, "invalid_request",
               "f_numbers or iris_positions");
  expect_error({{"kind", "lens_map"}, {"f_numbers", {2}}}, "invalid_request",
               "positions, or start, stop and step");
  expect_error(
      {{"kind", "lens_map"}, {"f_numbers", {2}}, {"positions", {0}}, {"exposures_us", {1}}},
      "invalid_request");
  // 8 stops x 126 positions: over the 1000 steps a capture may have.
  expect_error({{"kind", "lens_map"},
                {"iris_positions", {0, 1, 2, 3, 4, 5, 6, 7}},
                {"start", 0},
                {"stop", 1250},
                {"step", 10}},
               "invalid_request", "at most 1000");
}

// base_exposure_us holds the exposure H = T x E across the stops: each stop's time is the
// first's x (N / first N)^2, on the exposure grid, the time asked in `requested`.
TEST_F(CapturePlanTest, LensMapHoldsTheExposureAcrossStopsWithABaseTime) {
  auto p = plan({{"kind", "lens_map"},
                 {"f_numbers", {2, 4, 5.6}},
                 {"positions", {0, 50}},
                 {"base_exposure_us", 1000}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 6u);
  const int64_t units[6] = {10, 10, 40, 40, 78, 78};  // 1000, 4000 and 7840 us
  for (size_t i = 0; i < 6; ++i) {
    const CaptureStep& step = p->steps[i];
    EXPECT_EQ(step.controls.at("exposure_time_absolute"), units[i]) << i;
    const double n = step.requested["f_number"].get<double>();
    // T / N^2 is the same at every stop: the exposure is held.
    EXPECT_NEAR(step.requested["exposure_us"].get<double>() / (n * n), 1000.0 / 4, 1e-9) << i;
  }
  EXPECT_FALSE(p->fixed_controls.count("exposure_time_absolute"));
  EXPECT_EQ(p->fixed_controls.at("auto_exposure"), 1);
  // Every stop's time must fit the camera's range (1-100 units here): 1 ms at f/1.4 is
  // 16 ms at f/5.6, refused naming that stop, before anything moves.
  expect_error({{"kind", "lens_map"},
                {"f_numbers", {1.4, 5.6}},
                {"positions", {0}},
                {"base_exposure_us", 1000}},
               "out_of_range", "f/5.6");
  expect_error({{"kind", "lens_map"},
                {"f_numbers", {2}},
                {"positions", {0}},
                {"base_exposure_us", 1000},
                {"exposure_us", 1000}},
               "invalid_request", "not both");
  expect_error(
      {{"kind", "lens_map"}, {"f_numbers", {2}}, {"positions", {0}}, {"base_exposure_us", -5}},
      "invalid_request", "positive");
  // Stops of unknown f-number cannot be held.
  auto untabled = plan({{"kind", "lens_map"},
                        {"iris_positions", {3, 6}},
                        {"positions", {0}},
                        {"base_exposure_us", 1000}},
                       false);
  ASSERT_FALSE(untabled.ok());
  EXPECT_EQ(untabled.error().code, "unsupported") << untabled.error().message;
}

// An aperture series takes the same hold: each stop exposed alike, where one time would
// leave f/8 four stops under f/2 (a CoC measurement then reads its stopped-down edges
// through four times the noise).
TEST_F(CapturePlanTest, ApertureSeriesHoldsTheExposureWithABaseTime) {
  auto p = plan({{"kind", "aperture_series"}, {"f_numbers", {2, 4, 8}}, {"base_exposure_us", 500}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->steps.size(), 3u);
  const int64_t units[3] = {5, 20, 80};
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(p->steps[i].controls.at("exposure_time_absolute"), units[i]) << i;
    EXPECT_EQ(p->steps[i].controls.at("iris_absolute"), p->steps[i].requested["iris_position"]);
  }
  EXPECT_EQ(p->fixed_controls.at("auto_exposure"), 1);
  // Without it the series keeps one time (the 1/N^2 law's own check needs that).
  auto fixed = plan({{"kind", "aperture_series"}, {"f_numbers", {2, 8}}, {"exposure_us", 500}});
  ASSERT_TRUE(fixed.ok()) << fixed.error().message;
  EXPECT_FALSE(fixed->steps[1].controls.count("exposure_time_absolute"));
  EXPECT_EQ(fixed->fixed_controls.at("exposure_time_absolute"), 5);
  expect_error({{"kind", "aperture_series"}, {"f_numbers", {2, 8}}, {"base_exposure_us", 1000}},
               "out_of_range", "f/8");
}

TEST_F(CapturePlanTest, MalformedRequestsAreInvalid) {
  expect_error(json::array(), "invalid_request");
  expect_error({{"repeats", 1}}, "invalid_request", "kind is required");
  expect_error({{"kind", "timelapse"}}, "invalid_request", "unknown kind");
  expect_error({{"kind", "single"}, {"exposure_ms", 4}}, "invalid_request",
               "unknown field 'exposure_ms'");
  expect_error({{"kind", "bracket"}, {"exposures_us", 1000}}, "invalid_request", "must be a list");
  expect_error({{"kind", "bracket"}, {"exposures_us", json::array()}}, "invalid_request",
               "must not be empty");
  expect_error({{"kind", "bracket"}, {"exposures_us", {"1000"}}}, "invalid_request",
               "must be a number");
  expect_error({{"kind", "bracket"}, {"exposures_us", {1000}}, {"ev_steps", {0}}},
               "invalid_request");
  expect_error({{"kind", "bracket"}, {"exposures_us", {1000}}, {"exposure_us", 1000}},
               "invalid_request");
  expect_error({{"kind", "single"}, {"repeats", 0}}, "invalid_request", "1..5000");
  expect_error({{"kind", "single"}, {"repeats", 5001}}, "invalid_request", "1..5000");
  expect_error({{"kind", "single"}, {"label", std::string(300, 'x')}}, "invalid_request");
}

TEST_F(CapturePlanTest, SizesAreBounded) {
  expect_error({{"kind", "bracket"}, {"exposures_us", std::vector<int>(1001, 1000)}},
               "invalid_request", "at most 1000");
  expect_error(
      {{"kind", "bracket"}, {"exposures_us", std::vector<int>(100, 1000)}, {"repeats", 100}},
      "invalid_request", "at most 5000");
  EXPECT_TRUE(plan({{"kind", "single"}, {"repeats", 300}}).ok()) << "a long single capture";
}

TEST_F(CapturePlanTest, FormatsAreCheckedAgainstWhatTheCameraOffers) {
  auto grey =
      plan({{"kind", "single"}, {"format", {{"fourcc", "GREY"}, {"width", 32}, {"height", 24}}}});
  ASSERT_TRUE(grey.ok()) << grey.error().message;
  EXPECT_EQ(grey->format.fourcc, "GREY");
  EXPECT_EQ(grey->format.width, 32u);
  auto y16 =
      plan({{"kind", "single"}, {"format", {{"fourcc", "Y16"}, {"frame_interval_us", 20000}}}});
  ASSERT_TRUE(y16.ok()) << y16.error().message;
  EXPECT_EQ(y16->format.fourcc, "Y16 ") << "padded to four characters";
  EXPECT_EQ(y16->format.interval.numerator, 20000u);
  expect_error({{"kind", "single"}, {"format", {{"fourcc", "MJPG"}}}}, "out_of_range",
               "GREY, Y16 , YUYV");
  expect_error({{"kind", "single"}, {"format", {{"width", 10}, {"height", 10}}}}, "out_of_range",
               "64x48, 32x24");
  expect_error({{"kind", "single"}, {"format", {{"width", 64}}}}, "invalid_request");
  expect_error({{"kind", "single"}, {"format", {{"frame_interval_us", 5000}}}}, "out_of_range",
               "10000, 20000");
}

TEST_F(CapturePlanTest, FixedControlsAreCheckedAndMayNotContradictTheKind) {
  auto p = plan({{"kind", "single"}, {"controls", {{"gain", 400}, {"focus_absolute", 64}}}});
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->fixed_controls.at("focus_absolute"), 64);
  EXPECT_TRUE(p->steps[0].controls.empty());
  expect_error({{"kind", "single"}, {"controls", {{"warp_drive", 1}}}}, "invalid_request",
               "no such control");
  expect_error({{"kind", "single"}, {"controls", {{"gain", 99}}}}, "out_of_range", "[100, 1600]");
  expect_error({{"kind", "single"}, {"controls", {{"auto_exposure", 2}}}}, "out_of_range",
               "Manual Mode");
  expect_error({{"kind", "bracket"},
                {"exposures_us", {1000}},
                {"controls", {{"exposure_time_absolute", 10}}}},
               "invalid_request", "steps exposure_time_absolute");
  expect_error(
      {{"kind", "bracket"}, {"exposures_us", {1000}}, {"controls", {{"auto_exposure", 3}}}},
      "invalid_request", "contradicts");
}

}  // namespace
}  // namespace camlab::capture

namespace camlab::capture {
namespace {

// What a UVC webcam, a Bayer CSI sensor and a camera camlab cannot read list, and the
// format a plan without one takes: the one that keeps the most of the sensor's signal.
TEST(CapturePlanFormats, WithoutAFormatThePlanTakesTheRawestDeepestOne) {
  auto listing = [](std::vector<std::string> fourccs) {
    std::vector<device::PixelFormatInfo> formats;
    for (auto& f : fourccs) formats.push_back({f, f, {{640, 480, {{1, 30}}}}});
    return formats;
  };
  auto chosen = [&](std::vector<std::string> fourccs) {
    auto p = plan_capture({{"kind", "single"}}, {}, listing(std::move(fourccs)), {});
    return p.ok() ? p->format.fourcc : "error: " + p.error().message;
  };
  EXPECT_EQ(chosen({"MJPG", "YUYV"}), "YUYV") << "a webcam: linear YUYV before JPEG";
  EXPECT_EQ(chosen({"MJPG"}), "MJPG") << "JPEG when nothing else is offered";
  EXPECT_EQ(chosen({"BA81", "pRAA", "RG12", "YUYV"}), "RG12") << "12-bit raw first";
  EXPECT_EQ(chosen({"RG16", "Y16 "}), "Y16 ") << "mono before a mosaic at one depth";
  EXPECT_EQ(chosen({"H264", "GREY"}), "GREY") << "never a format camlab cannot read";
}

}  // namespace
}  // namespace camlab::capture
