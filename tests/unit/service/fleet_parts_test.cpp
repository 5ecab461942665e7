// The fleet's parts that need no database: a camera's published description reads back
// into the same capture plan as the camera itself gives, a synchronised capture's schedule
// and frame start times, the parent's comparison of the cameras (against skews worked out
// by hand), and the router's wrapping of a route.
#include <gtest/gtest.h>
#include <time.h>

#include <atomic>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/capture_plan.h"
#include "service/api/router.h"
#include "service/fleet/camera_description.h"
#include "service/jobs/sync_schedule.h"

namespace camlab::service {
namespace {

CameraSnapshot test_camera() {
  CameraSnapshot s;
  s.identity = {"v4l2:platform:vcam-0", "v4l2", "/dev/video0", "vcam", "camlab", "platform:vcam-0"};
  s.transport = "in-process virtual camera";
  s.available = true;
  device::ControlInfo exposure;
  exposure.id = 0x009a0902;
  exposure.name = "exposure_time_absolute";
  exposure.minimum = 1;
  exposure.maximum = 200;
  exposure.step = 1;
  exposure.default_value = 10;
  exposure.current = 10;
  exposure.unit = "100 us";
  device::ControlInfo auto_exposure;
  auto_exposure.name = "auto_exposure";
  auto_exposure.type = device::ControlType::kMenu;
  auto_exposure.minimum = 0;
  auto_exposure.maximum = 3;
  auto_exposure.menu = {{1, "Manual Mode"}, {3, "Aperture Priority Mode"}};
  auto_exposure.current = 1;
  device::ControlInfo iris;
  iris.name = "iris_absolute";
  iris.minimum = 0;
  iris.maximum = 7;
  iris.current = 5;
  s.controls = {exposure, auto_exposure, iris};
  device::PixelFormatInfo y16{"Y16 ", "16-bit Greyscale", {}};
  y16.sizes.push_back({160, 120, {{1, 50}, {1, 25}}});
  device::PixelFormatInfo grey{"GREY", "8-bit Greyscale", {}};
  grey.sizes.push_back({160, 120, {{1, 50}}});
  s.formats = {y16, grey};
  s.traits.sensor_bit_depth = 10;
  s.traits.black_level_dn = 32;
  s.traits.gain_unity = 100;
  s.traits.f_number_by_iris_position = {16, 11, 8, 5.6, 4, 2.8, 2, 1.4};
  s.traits.focal_mm = 8;
  s.traits.focus_extension_mm_per_step = 0.001;
  s.description = {{"id", s.identity.id}, {"name", s.identity.name}};
  return s;
}

TEST(CameraDescription, APublishedCameraPlansCapturesAsTheCameraItself) {
  const CameraSnapshot camera = test_camera();
  const nlohmann::json published = describe_for_fleet(camera);
  auto read = read_published_camera(nlohmann::json::parse(published.dump()));
  ASSERT_TRUE(read.ok()) << read.error().message;
  ASSERT_EQ(read->controls.size(), camera.controls.size());
  EXPECT_EQ(read->controls[1].menu, camera.controls[1].menu);
  EXPECT_EQ(read->controls[1].type, device::ControlType::kMenu);
  EXPECT_EQ(read->formats[0].sizes[0].intervals.size(), 2u);
  EXPECT_EQ(read->traits.f_number_by_iris_position, camera.traits.f_number_by_iris_position);
  for (const nlohmann::json& request :
       {nlohmann::json{{"kind", "single"}, {"repeats", 3}},
        nlohmann::json{{"kind", "bracket"}, {"exposures_us", {1000, 2000, 4000}}},
        nlohmann::json{{"kind", "aperture_series"}, {"f_numbers", {2.8, 5.6}}},
        nlohmann::json{{"kind", "bracket"}, {"exposures_us", {150}}},  // off the grid: 422
        nlohmann::json{{"kind", "single"},
                       {"format", {{"fourcc", "GREY"}, {"frame_interval_us", 40000}}}}}) {
    SCOPED_TRACE(request.dump());
    auto truth = capture::plan_capture(request, camera.controls, camera.formats, camera.traits);
    auto remote = capture::plan_capture(request, read->controls, read->formats, read->traits);
    ASSERT_EQ(truth.ok(), remote.ok());
    if (truth) {
      EXPECT_EQ(remote->request, truth->request);
      EXPECT_EQ(remote->total_frames(), truth->total_frames());
      EXPECT_EQ(remote->format.fourcc, truth->format.fourcc);
    } else {
      EXPECT_EQ(remote.error().code, truth.error().code);
      EXPECT_EQ(remote.error().message, truth.error().message);
    }
  }
  auto unopened = read_published_camera({{"id", "v4l2:x"}});
  ASSERT_FALSE(unopened.ok());
  EXPECT_EQ(unopened.error().code, ErrorCode::kInvalidArgument);
}

TEST(SyncSchedule, TheScheduleIsTakenOutOfTheRequest) {
  nlohmann::json request = {
      {"kind", "single"}, {"schedule", {{"start_at_unix_ms", 1700000000000}, {"max_late_ms", 20}}}};
  auto taken = take_schedule(&request);
  ASSERT_TRUE(taken.ok());
  ASSERT_TRUE(taken->has_value());
  EXPECT_EQ((*taken)->start_at_unix_ms, 1700000000000);
  EXPECT_EQ((*taken)->max_late_ms, 20);
  EXPECT_EQ(request, nlohmann::json({{"kind", "single"}}));
  nlohmann::json plain = {{"kind", "single"}};
  EXPECT_FALSE(take_schedule(&plain)->has_value());
  for (const nlohmann::json& schedule :
       {nlohmann::json(5), nlohmann::json{{"max_late_ms", 3}},
        nlohmann::json{{"start_at_unix_ms", 1.5}},
        nlohmann::json{{"start_at_unix_ms", 1}, {"max_late_ms", -1}}}) {
    nlohmann::json bad = {{"kind", "single"}, {"schedule", schedule}};
    auto refused = take_schedule(&bad);
    ASSERT_FALSE(refused.ok()) << schedule.dump();
    EXPECT_EQ(refused.error().code, ErrorCode::kInvalidRequest);
  }
}

int64_t now_unix_ms() {
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000 + now.tv_nsec / 1000000;
}

TEST(SyncSchedule, AStartIsWaitedForOrRefusedWhenTooLate) {
  const int64_t start_ms = now_unix_ms() + 60;
  auto met = wait_for_start({start_ms, 100}, nullptr, "unused");
  ASSERT_TRUE(met.ok()) << met.error().message;
  EXPECT_GE(*met, 0);
  EXPECT_GE(now_unix_ms(), start_ms);  // never before the start

  auto late = wait_for_start({now_unix_ms() - 5000, 100}, nullptr, "the reason given");
  ASSERT_FALSE(late.ok());
  EXPECT_EQ(late.error().code, ErrorCode::kBusy);
  EXPECT_NE(late.error().message.find("100 ms"), std::string::npos) << late.error().message;
  EXPECT_NE(late.error().message.find("the reason given"), std::string::npos)
      << late.error().message;

  std::atomic<bool> cancel{true};
  auto cancelled = wait_for_start({now_unix_ms() + 60000, 100}, &cancel, "unused");
  ASSERT_FALSE(cancelled.ok());
  EXPECT_EQ(cancelled.error().code, ErrorCode::kCancelled);
}

// A missed start names what kept the camera: its own latency probe first, then the
// worker's previous work when that ended after the start, else the job's late pick-up.
TEST(SyncSchedule, AMissedStartSaysWhatKeptTheCamera) {
  const CaptureSchedule schedule{1'000'000, 100};
  EXPECT_NE(why_late(schedule, 12, "job 3 (capture)", 1'000'500).find("control latency first (12"),
            std::string::npos);
  const std::string probe_at_start_up =
      why_late(schedule, 0,
               "measuring its control latency at start-up (40 frames, once per camera)", 1'000'700);
  EXPECT_NE(probe_at_start_up.find("busy until 700 ms after the start with measuring its control "
                                   "latency at start-up"),
            std::string::npos)
      << probe_at_start_up;
  EXPECT_NE(why_late(schedule, 0, "job 3 (capture)", 999'000).find("reached the camera late"),
            std::string::npos);
  EXPECT_NE(why_late(schedule, 0, "", 0).find("reached the camera late"), std::string::npos);
}

TEST(SyncSchedule, FrameStartsComeFromTheMonotonicTimestamps) {
  FrameStartLog log;
  // Frames 20 ms apart in sequence, with sequence 3 lost: kept frames 0, 1, 2 at 0, 1, 4.
  const int64_t base_ns = 5'000'000'000;
  const uint64_t sequences[] = {10, 11, 14};
  for (int i = 0; i < 3; ++i) {
    image::FrameSidecar sidecar;
    sidecar.sequence = sequences[i];
    sidecar.timestamp_ns = base_ns + static_cast<int64_t>(sequences[i] - 10) * 20'000'000;
    log.add(i, sidecar);
  }
  image::FrameSidecar rendered;
  rendered.clock = "virtual";
  rendered.sequence = 15;
  rendered.timestamp_ns = 1;
  log.add(3, rendered);
  const nlohmann::json json = log.to_json({1700000000000, 100}, 250);
  EXPECT_EQ(json["late_us"], 250);
  EXPECT_EQ(json["frame_interval_us"], 20000);
  const nlohmann::json& frames = json["frames"];
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[1]["start_unix_us"].get<int64_t>() - frames[0]["start_unix_us"].get<int64_t>(),
            20000);
  EXPECT_EQ(frames[2]["start_unix_us"].get<int64_t>() - frames[0]["start_unix_us"].get<int64_t>(),
            80000);
  EXPECT_TRUE(frames[3]["start_unix_us"].is_null());  // no Unix time for a virtual clock
}

JobRecord child(int64_t id, const std::string& host, JobState state,
                const std::vector<int64_t>& starts_us, int64_t interval_us) {
  JobRecord job;
  job.id = id;
  job.host = host;
  job.camera_id = "cam";
  job.state = state;
  nlohmann::json frames = nlohmann::json::array();
  for (size_t i = 0; i < starts_us.size(); ++i)
    frames.push_back({{"index", i}, {"sequence", 3 + i}, {"start_unix_us", starts_us[i]}});
  job.result = {
      {"synchronised", {{"frames", frames}, {"frame_interval_us", interval_us}, {"late_us", 7}}}};
  return job;
}

TEST(SyncSchedule, TheParentComparesTheCamerasFrameByFrame) {
  const int64_t start_ms = 1700000000000, t0 = start_ms * 1000;
  // Three cameras; skews worked out by hand: frame 0 spans t0+1000..t0+4000 (3000 us),
  // frame 1 t0+21000..t0+25000 (4000 us), frame 2 only on camera a (none).
  const std::vector<JobRecord> children = {
      child(11, "a", JobState::kSucceeded, {t0 + 1000, t0 + 21000, t0 + 41000}, 20000),
      child(12, "b", JobState::kSucceeded, {t0 + 4000, t0 + 24000}, 20000),
      child(13, "c", JobState::kSucceeded, {t0 + 2500, t0 + 25000}, 20010)};
  const nlohmann::json summary = summarize_sync_capture(
      start_ms, {"cam@a", "cam@b", "cam@c"}, children, {{"a", {12, 40}}, {"b", {-30, 41}}});
  EXPECT_EQ(summary["skew_us"]["per_view"], nlohmann::json({3000, 4000, nullptr}));
  EXPECT_EQ(summary["skew_us"]["first_view"], 3000);
  EXPECT_EQ(summary["skew_us"]["max"], 4000);
  EXPECT_EQ(summary["frame_interval_us"], 20000);  // the median of 20000, 20000, 20010
  EXPECT_DOUBLE_EQ(summary["skew_frames"].get<double>(), 0.2);
  ASSERT_EQ(summary["cameras"].size(), 3u);
  EXPECT_EQ(summary["cameras"][1]["camera"], "cam@b");
  EXPECT_EQ(summary["cameras"][1]["frames"][0]["after_start_us"], 4000);
  EXPECT_EQ(summary["cameras"][0]["late_us"], 7);
  EXPECT_EQ(summary["host_clocks"].size(), 2u);
  EXPECT_EQ(summary["host_clocks"][1]["offset_to_database_us"], -30);

  // A camera that failed is shown with its error and leaves the others' comparison alone.
  JobRecord failed;
  failed.id = 14;
  failed.state = JobState::kFailed;
  failed.error_code = "busy";
  failed.error_message = "the camera could begin only 900 ms after the synchronised start";
  const nlohmann::json partial =
      summarize_sync_capture(start_ms, {"cam@a", "cam@d"}, {children[0], failed}, {});
  EXPECT_EQ(partial["cameras"][1]["error"]["code"], "busy");
  EXPECT_TRUE(partial["skew_us"]["max"].is_null());  // one camera alone has no skew
}

// Rig views pair frames by start time: camera b dropped the second trigger's frame, so
// its second kept frame is the third trigger's. Pairing by order would give that view a
// skew of a whole interval; by time, the second view is incomplete and the third whole.
TEST(SyncSchedule, RigViewsPairFramesByStartTimeNotByOrder) {
  const int64_t start_ms = 1700000000000, t0 = start_ms * 1000;
  const std::vector<JobRecord> children = {
      child(21, "a", JobState::kSucceeded, {t0, t0 + 20000, t0 + 40000}, 20000),
      child(22, "a", JobState::kSucceeded, {t0 + 300, t0 + 40200}, 20000),
      child(23, "a", JobState::kSucceeded, {t0 + 1500, t0 + 21500, t0 + 41500}, 20000)};
  const nlohmann::json summary =
      summarize_sync_capture(start_ms, {"x@a", "y@a", "z@a"}, children, {}, 1000);
  // Each trigger's skew, not the 20200 us that pairing the cameras' second frames would give.
  EXPECT_EQ(summary["skew_us"]["per_view"], nlohmann::json({1500, 1500, 1500}));
  EXPECT_EQ(summary["skew_us"]["max"], 1500);
  const nlohmann::json& rig = summary["rig_views"];
  ASSERT_EQ(rig["views"].size(), 3u) << rig.dump(1);
  EXPECT_EQ(rig["views"][0]["frames"], nlohmann::json({0, 0, 0}));
  EXPECT_EQ(rig["views"][0]["skew_us"], 1500);
  EXPECT_EQ(rig["views"][1]["frames"], nlohmann::json({1, nullptr, 1}));
  EXPECT_FALSE(rig["views"][1]["complete"].get<bool>());
  EXPECT_EQ(rig["views"][2]["frames"], nlohmann::json({2, 1, 2}));
  EXPECT_EQ(rig["views"][2]["skew_us"], 1500);
  EXPECT_EQ(rig["complete"], 2);
  EXPECT_EQ(rig["incomplete"], 1);
  // Over the 1000 us bound: flagged, each.
  EXPECT_FALSE(rig["views"][0]["within_bound"].get<bool>());
  EXPECT_EQ(rig["over_bound"], 2);
  EXPECT_EQ(rig["worst_skew_us"], 1500);
  EXPECT_EQ(rig["max_skew_us"], 1000);
  // A looser bound passes them.
  const nlohmann::json loose =
      summarize_sync_capture(start_ms, {"x@a", "y@a", "z@a"}, children, {}, 2000);
  EXPECT_EQ(loose["rig_views"]["over_bound"], 0);
}

// Cameras on free clocks, 6 ms apart at a 10 ms interval: each of b's frames is nearer a's
// next frame than a's own, so the views pair them so (4 ms of skew), and the frames left at
// either end make views of one camera, whose skew is null, not zero.
TEST(SyncSchedule, AFrameHalfAnIntervalFromEveryOtherMakesAViewOfItsOwn) {
  const int64_t start_ms = 1700000000000, t0 = start_ms * 1000;
  const std::vector<JobRecord> children = {
      child(31, "a", JobState::kSucceeded, {t0, t0 + 10000, t0 + 20000}, 10000),
      child(32, "b", JobState::kSucceeded, {t0 + 6000, t0 + 16000, t0 + 26000}, 10000)};
  const nlohmann::json summary =
      summarize_sync_capture(start_ms, {"x@a", "y@b"}, children, {}, 1000);
  EXPECT_EQ(summary["skew_us"]["per_view"], nlohmann::json({nullptr, 4000, 4000, nullptr}));
  EXPECT_TRUE(summary["skew_us"]["first_view"].is_null());
  EXPECT_EQ(summary["skew_us"]["max"], 4000);
  const nlohmann::json& views = summary["rig_views"]["views"];
  ASSERT_EQ(views.size(), 4u) << views.dump(1);
  EXPECT_EQ(views[0]["frames"], nlohmann::json({0, nullptr}));
  EXPECT_EQ(views[1]["frames"], nlohmann::json({1, 0}));
  EXPECT_EQ(views[3]["frames"], nlohmann::json({nullptr, 2}));
  EXPECT_EQ(summary["rig_views"]["complete"], 2);
  EXPECT_EQ(summary["rig_views"]["incomplete"], 2);
}

TEST(RouterWrap, AWrapperAnswersOrPassesTheRequestOn) {
  Router router(nullptr, nullptr);
  router.add({"GET", "/v1/things/{id}", "a thing",
              [](const ApiRequest&, const PathParams& p, Reply reply) {
                reply(json_response(200, {{"local", p.at("id")}}));
              }});
  EXPECT_TRUE(router.wrap(
      "GET", "/v1/things/{id}",
      [](const ApiRequest& request, const PathParams& p, Reply reply, const Handler& next) {
        if (p.at("id").find('@') == std::string::npos) return next(request, p, std::move(reply));
        reply(json_response(307, {{"elsewhere", p.at("id")}}));
      }));
  EXPECT_FALSE(router.wrap("GET", "/v1/nothing", nullptr));
  std::vector<ApiResponse> answers;
  for (const char* path : {"/v1/things/7", "/v1/things/7@b"})
    router.dispatch({"GET", path, "", "", "", "", ""},
                    [&](ApiResponse response) { answers.push_back(std::move(response)); });
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[0].status, 200);
  EXPECT_EQ(nlohmann::json::parse(answers[0].body)["local"], "7");
  EXPECT_EQ(answers[1].status, 307);
}

}  // namespace
}  // namespace camlab::service
