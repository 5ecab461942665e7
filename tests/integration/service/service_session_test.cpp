// Guided calibration sessions end to end: camlabd with the wide 1280x800 virtual camera
// looking at the 14x10 chessboard, a test that moves the virtual board to each suggested
// pose (POST /v1/test/cameras/{id}/scene), the loop's state read over the API while
// views are taken, and the finished model's field of view against the camera spec's
// lens (computed here from the spec, not from anything the daemon reports).
#include <gtest/gtest.h>

#include <cmath>

#include "calib/lens_model.h"
#include "daemon_harness.h"
#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

const std::string kExamples = CAMLAB_SOURCE_DIR "/mock_device/examples/";

class ServiceSession : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fresh_test_dir(std::string("session_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    ASSERT_TRUE(daemon.start(dir, {"--no-scan", "--test-faults", "--camera-spec",
                                   kExamples + "camera_wide_1280x800.json", "--scene",
                                   kExamples + "scene_chessboard_calibration.json"}))
        << daemon.log();
    camera_id = daemon.camera_id();
  }
  void TearDown() override {
    daemon.stop(SIGTERM);
    fs::remove_all(dir);
  }
  json board_request() const {
    return {{"camera", camera_id},
            {"inner_corners", {14, 10}},
            {"spacing_m", 0.04},
            {"model", "LENSMODEL_OPENCV8"},
            {"target_uncertainty_px", 0.5}};
  }
  // Polls the session until its phase is `phase` (bounded); every answer is 200 and
  // names a known phase. Returns the last state; counts the phases seen on the way.
  json wait_phase(int64_t id, const std::string& phase, std::set<std::string>* seen) const {
    json state;
    // Bounded at about 2 minutes: the first view waits for the camera's start-up latency
    // probe, which a loaded 2-core machine can stretch.
    for (int i = 0; i < 4800; ++i) {
      auto r = daemon.get("/v1/calibration-sessions/" + std::to_string(id));
      EXPECT_EQ(r.status, 200) << r.body;
      state = r.json();
      if (seen) seen->insert(state.value("phase", ""));
      if (state.value("phase", "") == phase) return state;
      std::this_thread::sleep_for(25ms);
    }
    ADD_FAILURE() << "session " << id << " never reached phase " << phase << ": " << state.dump();
    return state;
  }
  fs::path dir;
  Daemon daemon;
  std::string camera_id;
};

// The lens the virtual camera renders with, at the focus its default settings give.
camlab::calib::FieldOfView truth_fov() {
  auto camera = camlab::mock::load_camera_spec(kExamples + "camera_wide_1280x800.json");
  auto scene = camlab::mock::load_scene_spec(kExamples + "scene_chessboard_calibration.json");
  EXPECT_TRUE(camera.ok() && scene.ok());
  auto renderer = camlab::mock::Renderer::create(*camera, *scene);
  EXPECT_TRUE(renderer.ok());
  camlab::mock::RenderOptions options;
  options.noise = false;
  auto frame = renderer->render(renderer->default_settings(), 0, options);
  EXPECT_TRUE(frame.ok());
  const double lens_to_sensor_mm = frame->settings["lens_to_sensor_mm"].get<double>();
  camlab::calib::LensModel truth{camera->lens.model,
                                 camlab::mock::intrinsics_at(*camera, lens_to_sensor_mm),
                                 camera->sensor.width_px, camera->sensor.height_px};
  auto fov = camlab::calib::field_of_view(truth);
  EXPECT_TRUE(fov.ok());
  return fov.ok() ? *fov : camlab::calib::FieldOfView{};
}

TEST_F(ServiceSession, GuidedLoopReachesItsTargetAndFinishesIntoAModel) {
  auto opened = daemon.post("/v1/calibration-sessions", board_request());
  ASSERT_EQ(opened.status, 201) << opened.body;
  const int64_t id = opened.json()["id"];
  EXPECT_EQ(opened.json()["phase"], "ready");
  EXPECT_EQ(opened.headers["location"], "/v1/calibration-sessions/" + std::to_string(id));
  // Not enough views to finish.
  EXPECT_EQ(
      daemon.post("/v1/calibration-sessions/" + std::to_string(id) + "/finish", json::object())
          .status,
      422);

  std::set<std::string> phases_seen;
  std::vector<double> worst_px, view_s;
  json state;
  const int max_views = 16;
  int views = 0;
  for (; views < max_views; ++views) {
    const auto view_start = std::chrono::steady_clock::now();
    auto taken =
        daemon.post("/v1/calibration-sessions/" + std::to_string(id) + "/views", json::object());
    ASSERT_EQ(taken.status, 202) << taken.body;
    EXPECT_EQ(taken.json()["phase"], "capturing");
    // One view at a time.
    auto again =
        daemon.post("/v1/calibration-sessions/" + std::to_string(id) + "/views", json::object());
    if (again.status != 202)
      EXPECT_EQ(again.status, 409) << again.body;
    else  // the first view finished in between: wait for the second one too
      ++views;
    state = wait_phase(id, "ready", &phases_seen);
    view_s.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - view_start).count());
    ASSERT_FALSE(state["frames"].empty());
    EXPECT_TRUE(state["frames"].back()["board_found"].get<bool>()) << state.dump(1);
    if (!state["uncertainty"].is_null()) worst_px.push_back(state["uncertainty"]["worst_px"]);
    if (state["target_reached"].get<bool>()) break;
    // Place the board where the session suggests.
    ASSERT_TRUE(state["suggestion"].is_object()) << state.dump(1);
    auto moved = daemon.post("/v1/test/cameras/" + url_segment(camera_id) + "/scene",
                             {{"target", "board"}, {"pose", state["suggestion"]["rt_cam_board"]}});
    ASSERT_EQ(moved.status, 200) << moved.body;
  }
  RecordProperty("views", views + 1);
  std::printf("guided session: %zu frames, worst uncertainty by view:", state["frames"].size());
  for (double w : worst_px) std::printf(" %.3f", w);
  std::printf(" px; seconds by view (capture, detect, solve, suggest):");
  for (double t : view_s) std::printf(" %.2f", t);
  std::printf("\n");
  EXPECT_TRUE(state["target_reached"].get<bool>()) << state.dump(1);
  ASSERT_GE(worst_px.size(), 2u);
  EXPECT_LT(worst_px.back(), worst_px.front());
  // The state was served while views were taken.
  EXPECT_TRUE(phases_seen.count("capturing") || phases_seen.count("solving"));

  auto finishing =
      daemon.post("/v1/calibration-sessions/" + std::to_string(id) + "/finish", json::object());
  ASSERT_EQ(finishing.status, 202) << finishing.body;
  const json ended = wait_phase(id, "ended", nullptr);
  ASSERT_EQ(ended["state"], "succeeded") << ended.dump(1);
  const json& report = ended["report"];
  const camlab::calib::FieldOfView truth = truth_fov();
  const json fov = report.contains("fov_deg") ? report["fov_deg"] : report["model"]["fov_deg"];
  ASSERT_TRUE(fov.is_object()) << report.dump(1).substr(0, 2000);
  const double h = fov["horizontal"], v = fov["vertical"];
  std::printf("finished: FOV %.3f x %.3f deg (truth %.3f x %.3f)\n", h, v, truth.horizontal_deg,
              truth.vertical_deg);
  EXPECT_NEAR(h, truth.horizontal_deg, 0.3);
  EXPECT_NEAR(v, truth.vertical_deg, 0.3);
  EXPECT_TRUE(fs::exists(dir / "data" / ended["folder"].get<std::string>() / "camera.cameramodel"));
  // The session is also a job, and an ended session takes no more views.
  EXPECT_EQ(daemon.get("/v1/jobs/" + std::to_string(id)).json()["kind"], "calibration_session");
  EXPECT_EQ(daemon.post("/v1/calibration-sessions/" + std::to_string(id) + "/views", json::object())
                .status,
            409);
}

// A second view with the board where it was adds no geometry: it is refused with the
// view it repeats, and the views, solution and suggestion stay as they were.
TEST_F(ServiceSession, AViewOfTheSamePoseIsRefusedWithTheViewItRepeats) {
  auto opened = daemon.post("/v1/calibration-sessions", board_request());
  ASSERT_EQ(opened.status, 201) << opened.body;
  const int64_t id = opened.json()["id"];
  const std::string views = "/v1/calibration-sessions/" + std::to_string(id) + "/views";
  ASSERT_EQ(daemon.post(views, json::object()).status, 202);
  const json first = wait_phase(id, "ready", nullptr);
  ASSERT_EQ(first["views_with_board"], 1) << first.dump(1);
  ASSERT_EQ(daemon.post(views, json::object()).status, 202);
  const json second = wait_phase(id, "ready", nullptr);
  ASSERT_EQ(second["frames"].size(), 2u) << second.dump(1);
  const json& repeat = second["frames"][1];
  EXPECT_TRUE(repeat["board_found"].get<bool>());
  EXPECT_EQ(repeat["duplicate_of"], 0) << repeat.dump();
  EXPECT_TRUE(repeat["view"].is_null()) << repeat.dump();
  EXPECT_EQ(second["frames"][0]["view"], 0);
  EXPECT_EQ(second["views_with_board"], 1);
  ASSERT_TRUE(second["last_error"].is_object()) << second.dump(1);
  EXPECT_EQ(second["last_error"]["code"], "duplicate_view");
  EXPECT_NE(second["last_error"]["message"].get<std::string>().find("view 0"), std::string::npos)
      << second["last_error"].dump();
  EXPECT_EQ(second["suggestion"], first["suggestion"]);
}

TEST_F(ServiceSession, BadRequestsAreRefusedWithSpecificErrors) {
  json unknown_camera = board_request();
  unknown_camera["camera"] = "no-such-camera";
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", unknown_camera).status, 404);
  json bad_target = board_request();
  bad_target["target_uncertainty_px"] = 0;
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", bad_target).status, 422);
  json bad_model = board_request();
  bad_model["model"] = "LENSMODEL_NOPE";
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", bad_model).status, 422);
  json extra = board_request();
  extra["zoom"] = 2;
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", extra).status, 400);
  json charuco_without_markers = board_request();
  charuco_without_markers["detector"] = "charuco";
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", charuco_without_markers).status, 422);
  EXPECT_EQ(daemon.get("/v1/calibration-sessions/999999").status, 404);
  EXPECT_EQ(daemon.get("/v1/calibration-sessions/abc").status, 400);
  // A capture job is not a session.
  auto capture =
      daemon.post("/v1/cameras/" + url_segment(camera_id) + "/captures", {{"kind", "single"}});
  ASSERT_EQ(capture.status, 202);
  EXPECT_EQ(
      daemon.get("/v1/calibration-sessions/" + std::to_string(capture.json()["id"].get<int64_t>()))
          .status,
      404);
  // Sessions are bounded; a cancelled one frees its place.
  std::vector<int64_t> open;
  for (int i = 0; i < 4; ++i) {
    auto r = daemon.post("/v1/calibration-sessions", board_request());
    ASSERT_EQ(r.status, 201) << r.body;
    open.push_back(r.json()["id"]);
  }
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", board_request()).status, 429);
  auto cancelled = daemon.del("/v1/calibration-sessions/" + std::to_string(open[0]));
  EXPECT_EQ(cancelled.status, 200) << cancelled.body;
  EXPECT_EQ(daemon.get("/v1/calibration-sessions/" + std::to_string(open[0])).json()["state"],
            "cancelled");
  EXPECT_EQ(daemon.post("/v1/calibration-sessions", board_request()).status, 201);
  // Moving a target that is not in the scene.
  EXPECT_EQ(daemon
                .post("/v1/test/cameras/" + url_segment(camera_id) + "/scene",
                      {{"target", "kite"}, {"pose", {0, 0, 0, 0, 0, 1}}})
                .status,
            404);
  EXPECT_EQ(daemon
                .post("/v1/test/cameras/" + url_segment(camera_id) + "/scene",
                      {{"target", "board"}, {"pose", {0, 0, 0, 0, 0, -1}}})
                .status,
            422);
}

}  // namespace
