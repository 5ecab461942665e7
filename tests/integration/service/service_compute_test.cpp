// POST /v1/analyses and POST /v1/calibrations: jobs running the analysis and calibration
// libraries on capture folders (a daemon capture, and a rendered calibration set placed
// under the data folder), with their sources validated.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <thread>

#include "daemon_harness.h"
#include "tests/integration/cli_runner.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

// The first value stored under `key` anywhere in `j`, or null.
json find_key(const json& j, const std::string& key) {
  if (j.is_object()) {
    if (j.contains(key)) return j[key];
    for (const auto& [k, v] : j.items())
      if (auto found = find_key(v, key); !found.is_null()) return found;
  } else if (j.is_array()) {
    for (const auto& v : j)
      if (auto found = find_key(v, key); !found.is_null()) return found;
  }
  return nullptr;
}

class ServiceCompute : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fresh_test_dir(std::string("compute_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    write_test_specs(dir);
    ASSERT_TRUE(daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(),
                                   "--scene", (dir / "scene.json").string()}))
        << daemon.log();
    camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  }
  void TearDown() override {
    daemon.stop(SIGTERM);
    fs::remove_all(dir);
  }
  fs::path dir;
  Daemon daemon;
  std::string camera;
};

TEST_F(ServiceCompute, ExposureAnalysisOfABracketReportsLinearity) {
  auto capture = daemon.post(camera + "/captures", {{"kind", "bracket"},
                                                    {"exposures_us", {2000, 4000, 8000}},
                                                    {"repeats", 2},
                                                    {"controls", {{"iris_absolute", 5}}}});
  ASSERT_EQ(capture.status, 202) << capture.body;
  const int64_t capture_id = capture.json()["id"];
  // A source that is still running is refused.
  auto early = daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", capture_id}});
  if (early.status != 202) {
    EXPECT_EQ(early.status, 409) << early.body;
  }
  ASSERT_EQ(daemon.wait_finished(capture_id)["state"], "succeeded");
  auto r = daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", capture_id}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"]);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json linearity_error = find_key(job["result"]["report"], "max_abs_error_pct");
  ASSERT_TRUE(linearity_error.is_number()) << job["result"].dump();
  EXPECT_LT(linearity_error.get<double>(), 2.0) << job["result"]["report"]["linearity"].dump();
}

// kind "sfr": the slanted-edge SFR of a capture's frames, the same run as `camlab analyze
// sfr DIR`; the test scene's 5 deg edge is measured in every frame.
TEST_F(ServiceCompute, SfrAnalysisMeasuresTheSceneEdgeInEveryFrame) {
  auto capture = daemon.post(camera + "/captures",
                             {{"kind", "bracket"}, {"exposures_us", {2000, 4000}}, {"repeats", 1}});
  ASSERT_EQ(capture.status, 202) << capture.body;
  const int64_t capture_id = capture.json()["id"];
  ASSERT_EQ(daemon.wait_finished(capture_id)["state"], "succeeded");
  auto r = daemon.post("/v1/analyses", {{"kind", "sfr"}, {"job", capture_id}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"]);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json& report = job["result"]["report"];
  EXPECT_EQ(report["kind"], "sfr");
  ASSERT_EQ(report["frames"].size(), 2u) << report.dump();
  for (const json& frame : report["frames"]) {
    int near_five_degrees = 0;
    for (const json& edge : frame["edges"])
      if (edge["status"] == "ok" && std::fabs(edge["slant_deg"].get<double>() - 5.0) < 0.2) {
        ++near_five_degrees;
        const double mtf50 = edge["mtf50_cy_px"];
        EXPECT_GT(mtf50, 0.02);
        EXPECT_LT(mtf50, 0.7);  // a pixel's own area holds it under 0.6 cycles/px
      }
    EXPECT_GE(near_five_degrees, 1) << frame.dump().substr(0, 1500);
  }
  // An unknown kind names the ones there are.
  auto bad = daemon.post("/v1/analyses", {{"kind", "mtf"}, {"job", capture_id}});
  EXPECT_EQ(bad.status, 400) << bad.body;
  EXPECT_NE(bad.body.find("sfr"), std::string::npos) << bad.body;
}

TEST_F(ServiceCompute, SourcesAreValidated) {
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", 4242}}).status, 404);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "colour"}, {"job", 1}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "../../etc"}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "/etc"}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "captures/none"}}).status,
            404);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}}).status, 400);
  fs::create_symlink("/etc", dir / "data" / "escape");
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "escape"}}).status, 400);
  EXPECT_EQ(daemon
                .post("/v1/calibrations",
                      {{"folder", "captures"}, {"inner_corners", {14}}, {"spacing_m", 0.04}})
                .status,
            400);
  // The wrong capture for the analysis (the review: an analysis job of the wrong kind
  // succeeded empty): refused at submission, naming the capture needed.
  auto single = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", 2}});
  ASSERT_EQ(single.status, 202) << single.body;
  const int64_t single_id = single.json()["id"];
  ASSERT_EQ(daemon.wait_finished(single_id)["state"], "succeeded");
  for (const char* kind : {"exposure", "focus"}) {
    auto wrong = daemon.post("/v1/analyses", {{"kind", kind}, {"job", single_id}});
    EXPECT_EQ(wrong.status, 422) << kind << ": " << wrong.body;
    EXPECT_EQ(wrong.error_code(), "invalid_argument") << wrong.body;
    EXPECT_NE(wrong.body.find(std::string(kind) == "exposure" ? "needs a bracket"
                                                              : "needs a focus stack"),
              std::string::npos)
        << wrong.body;
  }
}

// One front door (calib/calibration_request.h): the same bad calibration request gets the
// same code from `camlab calibrate` and from POST /v1/calibrations, and a model whose solve
// would overflow mrcal's stack (it killed camlabd with SIGSEGV) is refused at submission,
// never queued, with camlabd still serving.
TEST_F(ServiceCompute, TheSameBadCalibrationRequestGetsTheSameCodeFromCamlabAndCamlabd) {
  fs::create_directories(dir / "data" / "imports" / "empty-set");
  struct Case {
    json fields;       // merged over the good request
    std::string args;  // the same, as camlab calibrate's flags
    std::string code;
  };
  const std::string spline =
      "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2000_Ny=2000_fov_x_deg=170";
  const std::vector<Case> cases = {
      {{{"model", spline}}, "--model " + spline, "out_of_range"},
      {{{"model", "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=60_Ny=45_fov_x_deg=170"}},
       "--model LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=60_Ny=45_fov_x_deg=170",
       "out_of_range"},
      {{{"model", "LENSMODEL_NOPE"}}, "--model LENSMODEL_NOPE", "bad_lensmodel"},
      // 2^32 + 14 read as 14 before.
      {{{"inner_corners", {4294967310LL, 10}}}, "--board 4294967310x10", "out_of_range"},
      {{{"inner_corners", {1, 10}}}, "--board 1x10", "out_of_range"},
      {{{"spacing_m", 1e-300}}, "--spacing-m 1e-300", "out_of_range"},
      {{{"spacing_m", 11}}, "--spacing-m 11", "out_of_range"},
      {{{"pixel_um", 1e-300}}, "--pixel-um 1e-300", "out_of_range"},
      {{{"detector", "harris"}}, "--detector harris", "invalid_argument"},
      {{{"detector", "mrgingham"}}, "--detector mrgingham", "unsupported"},
      {{{"detector", "charuco"}}, "--detector charuco", "invalid_argument"},
      // Below the square in double, equal to it in float: OpenCV asserted ("internal").
      {{{"detector", "charuco"}, {"marker_m", 0.04 * (1 - 1e-12)}, {"dictionary", "DICT_4X4_250"}},
       "--detector charuco --marker-m 0.03999999999996 --dictionary DICT_4X4_250",
       "out_of_range"},
  };
  for (const Case& c : cases) {
    json body = {{"folder", "imports/empty-set"}, {"inner_corners", {14, 10}}, {"spacing_m", 0.04}};
    for (const auto& [key, value] : c.fields.items()) body[key] = value;
    auto answer = daemon.post("/v1/calibrations", body);
    EXPECT_EQ(answer.status, 422) << body.dump() << "\n" << answer.body;
    EXPECT_EQ(answer.error_code(), c.code) << body.dump() << "\n" << answer.body;

    std::string args = "calibrate --json --images " +
                       (dir / "data" / "imports" / "empty-set").string() + " --out " +
                       (dir / "never.cameramodel").string();
    if (c.args.find("--board") == std::string::npos) args += " --board 14x10";
    if (c.args.find("--spacing-m") == std::string::npos) args += " --spacing-m 0.04";
    const auto run = run_cli(args + " " + c.args);
    EXPECT_EQ(run.exit_code, 2) << args << " " << c.args << "\n" << run.err;
    const json cli = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(cli.is_object()) << run.out;
    EXPECT_EQ(cli["error"].value("code", ""), c.code) << c.args << "\n" << run.out;
  }
  // Nothing was queued, and camlabd is still serving.
  EXPECT_EQ(daemon.get("/v1/health").status, 200) << daemon.log();
  auto jobs = daemon.get("/v1/jobs");
  ASSERT_EQ(jobs.status, 200);
  EXPECT_TRUE(jobs.json()["jobs"].empty()) << jobs.body;
}

// 7 views of the wide camera's calibration scene, rendered into the capture folder `set`.
CliRun render_calibration_set(const fs::path& set) {
  return run_cli("render --camera " CAMLAB_SOURCE_DIR
                 "/mock_device/examples/camera_wide_1280x800.json --scene " CAMLAB_SOURCE_DIR
                 "/mock_device/examples/scene_chessboard_calibration.json --quiet"
                 " --view 0 --view 5 --view 10 --view 15 --view 20 --view 25 --view 30 --out " +
                 set.string());
}

// Lists each frame of the capture folder `set` `repeats` times in its journal: a long
// capture of the same frames, whose measurements are those of the frames once.
void repeat_frames(const fs::path& set, int repeats) {
  std::vector<json> lines;
  {
    std::ifstream in(set / "frames.jsonl");
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) lines.push_back(json::parse(line));
  }
  EXPECT_FALSE(lines.empty());
  std::ofstream out(set / "frames.jsonl", std::ios::trunc);
  int index = 0;
  for (int r = 0; r < repeats; ++r)
    for (json line : lines) {
      line["index"] = index++;
      out << line.dump() << "\n";
    }
  out.close();
  json manifest = json::parse(read_file(set / "manifest.json"));
  manifest["frame_count"] = index;
  std::ofstream(set / "manifest.json", std::ios::trunc) << manifest.dump(2);
}

// A running calibration or analysis stops on DELETE (it answered 409 before) and on
// SIGTERM (camlabd ran on for minutes, past a service manager's 30 s stop timeout).
TEST_F(ServiceCompute, ARunningCalibrationOrAnalysisStopsOnDeleteAndOnSigterm) {
  // The 7-view calibration set, 280 frames long: detection alone takes a minute on the
  // compute thread.
  const fs::path set = dir / "data" / "imports" / "long-set";
  ASSERT_EQ(render_calibration_set(set).exit_code, 0);
  repeat_frames(set, 40);
  const json request = {
      {"folder", "imports/long-set"}, {"inner_corners", {14, 10}}, {"spacing_m", 0.04}};
  auto first = daemon.post("/v1/calibrations", request);
  ASSERT_EQ(first.status, 202) << first.body;
  const int64_t first_id = first.json()["id"];
  json running = daemon.wait_job(first_id, [](const json& j) { return j["state"] != "queued"; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  auto cancel = daemon.del("/v1/jobs/" + std::to_string(first_id));
  EXPECT_EQ(cancel.status, 202) << cancel.body;
  const auto cancelled_at = std::chrono::steady_clock::now();
  auto cancelled = daemon.wait_finished(first_id, std::chrono::seconds(30));
  EXPECT_EQ(cancelled["state"], "cancelled") << cancelled.dump();
  const double stop_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - cancelled_at).count();
  std::printf("calibration stopped %.2f s after DELETE\n", stop_s);

  // An aperture series, 40 frames listed 100 times: a defocus analysis of a minute.
  const fs::path series = dir / "data" / "imports" / "long-series";
  const auto render = run_cli("render --camera " CAMLAB_SOURCE_DIR
                              "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
                              "/mock_device/examples/scene_slanted_edges.json --sweep "
                              "f_number=2:11.4:stops --repeats 8 --quiet --out " +
                              series.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  repeat_frames(series, 100);
  auto analysis =
      daemon.post("/v1/analyses", {{"kind", "defocus"}, {"folder", "imports/long-series"}});
  ASSERT_EQ(analysis.status, 202) << analysis.body;
  const int64_t analysis_id = analysis.json()["id"];
  running = daemon.wait_job(analysis_id, [](const json& j) { return j["state"] != "queued"; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  EXPECT_EQ(daemon.del("/v1/jobs/" + std::to_string(analysis_id)).status, 202);
  auto stopped = daemon.wait_finished(analysis_id, std::chrono::seconds(30));
  EXPECT_EQ(stopped["state"], "cancelled") << stopped.dump();

  auto second = daemon.post("/v1/calibrations", request);
  ASSERT_EQ(second.status, 202) << second.body;
  const int64_t second_id = second.json()["id"];
  running = daemon.wait_job(second_id, [](const json& j) { return j["state"] != "queued"; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  const auto term_at = std::chrono::steady_clock::now();
  // Exit status 0 within the 10 s bound (stop() kills and answers -1 past it).
  EXPECT_EQ(daemon.stop(SIGTERM, std::chrono::seconds(10)), 0) << daemon.log();
  const double exit_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - term_at).count();
  std::printf("camlabd exited %.2f s after SIGTERM with a calibration running\n", exit_s);
  ASSERT_TRUE(daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(),
                                 "--scene", (dir / "scene.json").string()}))
      << daemon.log();
  auto after = daemon.get("/v1/jobs/" + std::to_string(second_id));
  ASSERT_EQ(after.status, 200) << after.body;
  EXPECT_EQ(after.json()["state"], "interrupted") << after.body;
}

TEST_F(ServiceCompute, CalibrationOfARenderedChessboardSetRecoversTheFocalLength) {
  const fs::path set = dir / "data" / "imports" / "calibration-set";
  const auto render = render_calibration_set(set);
  ASSERT_EQ(render.exit_code, 0) << render.err;
  auto bad = daemon.post(
      "/v1/calibrations",
      {{"folder", "imports/calibration-set"}, {"inner_corners", {14, 10}}, {"spacing_m", -1}});
  EXPECT_EQ(bad.status, 422);
  // mrgingham finds square boards only: refused before any work, with the reason.
  auto not_square = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                                     {"inner_corners", {14, 10}},
                                                     {"spacing_m", 0.04},
                                                     {"detector", "mrgingham"}});
  EXPECT_EQ(not_square.status, 422) << not_square.body;
  EXPECT_NE(not_square.body.find("square"), std::string::npos) << not_square.body;
  EXPECT_EQ(daemon
                .post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                           {"inner_corners", {14, 10}},
                                           {"spacing_m", 0.04},
                                           {"detector", "harris"}})
                .status,
            422);  // invalid_argument, as `camlab calibrate --detector harris` says
  // A board larger than the one in the frames is found in none: a failed job that says
  // so, not an empty model. (A smaller one can be found inside the real board.)
  auto wrong_board = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                                      {"inner_corners", {15, 11}},
                                                      {"spacing_m", 0.04},
                                                      {"model", "LENSMODEL_OPENCV4"}});
  ASSERT_EQ(wrong_board.status, 202) << wrong_board.body;
  const json failed = daemon.wait_finished(wrong_board.json()["id"], std::chrono::seconds(300));
  EXPECT_EQ(failed["state"], "failed") << failed.dump();
  EXPECT_NE(failed.dump().find("no_board"), std::string::npos) << failed.dump();
  auto r = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                            {"inner_corners", {14, 10}},
                                            {"spacing_m", 0.04},
                                            {"model", "LENSMODEL_OPENCV8"}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"], std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_NE(job["result"]["cameramodel"].get<std::string>().find("LENSMODEL_OPENCV8"),
            std::string::npos);
  const json fx = find_key(job["result"]["report"], "fx_px");
  ASSERT_TRUE(fx.is_number()) << job["result"]["report"].dump();
  EXPECT_NEAR(fx.get<double>(), 2.2 / 0.003, 0.02 * 2.2 / 0.003)
      << "fx against the spec's f / pitch";
  // Both read the pixel pitch from the capture's manifest (camlab calibrate --job did not):
  // the focal length in mm against the spec's 2.2 mm.
  EXPECT_EQ(find_key(job["result"]["report"], "pixel_pitch_um"), 3.0);
  const auto cli = run_cli("calibrate --json --job " + set.string() +
                           " --board 14x10 --spacing-m 0.04 --model LENSMODEL_OPENCV8 --out " +
                           (dir / "cli.cameramodel").string());
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  const json cli_report = json::parse(cli.out);
  EXPECT_EQ(find_key(cli_report, "pixel_pitch_um"), 3.0) << cli.out.substr(0, 2000);
  const json focal_mm = find_key(cli_report, "focal_mm");
  ASSERT_TRUE(focal_mm.is_number()) << cli.out.substr(0, 2000);
  EXPECT_NEAR(focal_mm.get<double>(), 2.2, 0.02 * 2.2);
  // The model file is the CLI's: it carries mrcal's optimization inputs.
  std::ifstream model_file(dir / "data" / job["folder"].get<std::string>() / "camera.cameramodel");
  ASSERT_TRUE(model_file) << "no camera.cameramodel in the job's folder";
  const std::string model_text((std::istreambuf_iterator<char>(model_file)),
                               std::istreambuf_iterator<char>());
  EXPECT_NE(model_text.find("'optimization_inputs'"), std::string::npos);
  EXPECT_EQ(job["result"]["report"]["detector"]["requested"], "auto");
  // The plots the dashboard shows: residuals and the projection uncertainty, as PNG.
  std::set<std::string> plots;
  const std::string plots_path = "/v1/jobs/" + std::to_string(job["id"].get<int64_t>()) + "/plots";
  const json listed = daemon.get(plots_path).json();
  for (const auto& p : listed["plots"]) plots.insert(p["name"].get<std::string>());
  EXPECT_TRUE(plots.count("residuals.png")) << daemon.get(plots_path).body;
  EXPECT_TRUE(plots.count("uncertainty.png")) << daemon.get(plots_path).body;
  auto png = daemon.get(plots_path + "/residuals.png");
  EXPECT_EQ(png.status, 200);
  EXPECT_EQ(png.body.substr(1, 3), "PNG");
  // Every file the job wrote downloads byte for byte; nothing outside its folder does.
  const std::string files_path = "/v1/jobs/" + std::to_string(job["id"].get<int64_t>()) + "/files";
  const json files = daemon.get(files_path).json();
  std::set<std::string> written;
  for (const json& f : files["files"]) {
    const std::string relative = f["path"];
    written.insert(relative);
    auto got = daemon.get(f["url"].get<std::string>());
    ASSERT_EQ(got.status, 200) << relative;
    std::ifstream on_disk(dir / "data" / job["folder"].get<std::string>() / relative,
                          std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(on_disk)),
                            std::istreambuf_iterator<char>());
    EXPECT_EQ(got.body, bytes) << relative;
    EXPECT_EQ(f["bytes"].get<size_t>(), bytes.size()) << relative;
  }
  for (const char* expected : {"camera.cameramodel", "report.json", "plots/residuals.png"})
    EXPECT_TRUE(written.count(expected)) << expected << " not in " << files.dump();
  EXPECT_EQ(daemon.get(files_path + "/../../token").status, 404);
  EXPECT_EQ(daemon.get(files_path + "/..%2F..%2Ftoken").status, 400);  // no '/' in a segment
  EXPECT_EQ(daemon.get(files_path + "/plots/..").status, 404);
  EXPECT_EQ(daemon.get(files_path + "/no-such-file").status, 404);
}

// A ChArUco board through POST /v1/calibrations: views cut by the frame's edge kept
// (views 26-39 of the example set are cut), focal length against the spec's f / pitch.
TEST_F(ServiceCompute, CalibrationOfARenderedCharucoSetKeepsCutViews) {
  const fs::path set = dir / "data" / "imports" / "charuco-set";
  auto render =
      run_cli("render --camera " CAMLAB_SOURCE_DIR
              "/mock_device/examples/camera_wide_1280x800.json --scene " CAMLAB_SOURCE_DIR
              "/mock_device/examples/scene_charuco_calibration.json --quiet"
              " --view 0 --view 4 --view 8 --view 12 --view 16 --view 26 --view 30 --view 34"
              " --view 38 --out " +
              set.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const json board = {
      {"folder", "imports/charuco-set"}, {"inner_corners", {10, 7}}, {"spacing_m", 0.06},
      {"detector", "charuco"},           {"marker_m", 0.045},        {"dictionary", "DICT_4X4_50"},
      {"model", "LENSMODEL_OPENCV8"}};
  json too_big_marker = board;
  too_big_marker["marker_m"] = 0.07;
  EXPECT_EQ(daemon.post("/v1/calibrations", too_big_marker).status, 422);
  json unknown_dictionary = board;
  unknown_dictionary["dictionary"] = "DICT_9X9_1";
  EXPECT_GE(daemon.post("/v1/calibrations", unknown_dictionary).status, 400);
  json markers_without_charuco = board;
  markers_without_charuco["detector"] = "auto";
  // invalid_argument, the code `camlab calibrate --marker-m` without charuco gives.
  EXPECT_EQ(daemon.post("/v1/calibrations", markers_without_charuco).status, 422);
  auto r = daemon.post("/v1/calibrations", board);
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"], std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json fx = find_key(job["result"]["report"], "fx_px");
  ASSERT_TRUE(fx.is_number()) << job["result"]["report"].dump();
  EXPECT_NEAR(fx.get<double>(), 2.2 / 0.003, 0.02 * 2.2 / 0.003);
  EXPECT_EQ(job["result"]["report"]["detector"]["requested"], "charuco");
}

// A two-camera rig through camlabd: the README's wide camera and a copy of it 0.1 m to its
// right, the same seven board poses rendered for each (each camera's frames in a capture
// folder of its own, named alike), calibrated as one rig by POST /v1/calibrations.
TEST_F(ServiceCompute, RigCalibrationOfTwoRenderedCamerasFindsTheirBaseline) {
  const fs::path scene_dir = dir / "rig-scenes";
  fs::create_directories(scene_dir);
  json scene = json::parse(read_file(fs::path(CAMLAB_SOURCE_DIR) /
                                     "mock_device/examples/scene_chessboard_calibration.json"));
  std::ofstream(scene_dir / "camera-0.json") << scene.dump();
  // Camera 1 sits 0.1 m along camera 0's x axis, turned as camera 0: a board's pose in its
  // frame is the same rotation, 0.1 m further left.
  for (auto& target : scene["targets"])
    if (target.contains("poses"))
      for (auto& pose : target["poses"]) pose[3] = pose[3].get<double>() - 0.1;
  std::ofstream(scene_dir / "camera-1.json") << scene.dump();
  for (int c = 0; c < 2; ++c) {
    const auto render = run_cli(
        "render --camera " CAMLAB_SOURCE_DIR
        "/mock_device/examples/camera_wide_1280x800.json "
        "--scene " +
        (scene_dir / ("camera-" + std::to_string(c) + ".json")).string() +
        " --quiet --view 0 --view 5 --view 10 --view 15 --view 20 --view 25 --view 30 --out " +
        (dir / "data" / "imports" / ("rig-" + std::to_string(c))).string());
    ASSERT_EQ(render.exit_code, 0) << render.err;
  }
  const json rig = json::array({{{"folder", "imports/rig-0"}}, {{"folder", "imports/rig-1"}}});
  auto one = daemon.post("/v1/calibrations", {{"rig", json::array({{{"folder", "imports/rig-0"}}})},
                                              {"inner_corners", {14, 10}},
                                              {"spacing_m", 0.04}});
  EXPECT_EQ(one.status, 400) << one.body;
  auto both = daemon.post("/v1/calibrations", {{"rig", rig},
                                               {"folder", "imports/rig-0"},
                                               {"inner_corners", {14, 10}},
                                               {"spacing_m", 0.04}});
  EXPECT_EQ(both.status, 400) << both.body;
  auto r = daemon.post("/v1/calibrations", {{"rig", rig},
                                            {"inner_corners", {14, 10}},
                                            {"spacing_m", 0.04},
                                            {"model", "LENSMODEL_OPENCV8"}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"], std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json& camera1 = job["result"]["report"]["cameras"][1];
  const auto rt = camera1["rt_cam_ref"].get<std::vector<double>>();
  std::printf(
      "rig through camlabd: camera 1 rt_cam_ref %.5f %.5f %.5f rad, %.5f %.5f %.5f m; "
      "baseline %.3f +- %.3f mm\n",
      rt[0], rt[1], rt[2], rt[3], rt[4], rt[5], camera1["baseline_m"].get<double>() * 1000,
      camera1["baseline_sigma_mm"].get<double>());
  EXPECT_NEAR(camera1["baseline_m"].get<double>(), 0.1, 0.001);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(rt[k], 0, 0.05 * M_PI / 180) << k;
  EXPECT_NEAR(rt[3], -0.1, 0.001);
  for (const auto& file : job["result"]["cameramodel_files"])
    EXPECT_TRUE(fs::exists(dir / "data" / file.get<std::string>())) << file;
}

}  // namespace

// A rig on one machine: camlabd alone (SQLite, no fleet) serving a 3-camera virtual rig
// captures it at a common start (POST /v1/sync-captures on its own cameras); every rig
// view's frames start within 1 ms, each view's skew reported, and the capture is what a
// rig calibration takes.
TEST(ServiceRigAlone, AThreeCameraRigIsCapturedInSyncWithoutAFleet) {
  const fs::path dir = fresh_test_dir("rig_alone");
  json camera = json::parse(
      read_file(fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples/camera_wide_1280x800.json"));
  camera["sensor"]["width_px"] = 320;
  camera["sensor"]["height_px"] = 200;
  camera["sensor"]["pixel_pitch_um"] = 12.0;
  camera["lens"]["principal_point_px"] = {160.55, 99.45};
  camera["timing"]["frame_interval_us"] = 100000;  // 10 frames/s: rendered in time on 2 cores
  json cameras = json::array();
  for (int c = 0; c < 3; ++c)
    cameras.push_back({{"camera", camera}, {"rt_cam_ref", {0, 0, 0, -0.1 * c, 0, 0}}});
  std::ofstream(dir / "rig.json") << json{
      {"scene", CAMLAB_SOURCE_DIR "/mock_device/examples/scene_chessboard_calibration.json"},
      {"view_every_frames", 1},
      {"cameras", cameras}}.dump();
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, {"--no-scan", "--rig", (dir / "rig.json").string()}))
      << daemon.log();
  // Each camera measures its control latency at start (a job of its own); a synchronised
  // start while one is busy would be refused as late. Bounded: 600 x 100 ms.
  json listed_json;
  for (int poll = 0; poll < 600; ++poll) {
    const auto listed = daemon.get("/v1/cameras");
    ASSERT_EQ(listed.status, 200) << listed.body;
    listed_json = listed.json();
    bool measuring = false;
    for (const json& c : listed_json["cameras"])
      measuring |= c.value("measuring_latency", false) || !c["running_job"].is_null();
    if (!measuring) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::vector<std::string> ids;
  for (const json& c : listed_json["cameras"]) ids.push_back(c["id"].get<std::string>());
  ASSERT_EQ(ids.size(), 3u) << listed_json.dump();

  auto unknown = daemon.post("/v1/sync-captures",
                             {{"cameras", {ids[0], "nothing"}}, {"capture", {{"kind", "single"}}}});
  EXPECT_EQ(unknown.status, 404) << unknown.body;
  EXPECT_NE(unknown.body.find(ids[1]), std::string::npos) << "lists the cameras: " << unknown.body;

  auto posted = daemon.post(
      "/v1/sync-captures",
      {{"cameras", ids}, {"capture", {{"kind", "single"}, {"repeats", 8}}}, {"start_in_ms", 1000}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t capture = posted.json()["id"];
  const json captured = daemon.wait_job(
      capture, [](const json& j) { return j["state"] != "queued" && j["state"] != "running"; },
      std::chrono::seconds(120));
  ASSERT_EQ(captured["state"], "succeeded") << captured.dump(1).substr(0, 3000);
  const json& result = captured["result"];
  const json& views = result["rig_views"];
  EXPECT_GE(views["complete"].get<int>(), 6) << views.dump(1);
  EXPECT_EQ(views["over_bound"], 0) << views.dump(1);
  // The rig views' skew (frames grouped by start time): under load a camera may begin one
  // tick later, which leaves a view incomplete, not a whole interval of skew; "skew_us" is
  // taken from the views too.
  ASSERT_TRUE(views["worst_skew_us"].is_number_integer()) << views.dump(1);
  const int64_t worst_us = views["worst_skew_us"].get<int64_t>();
  EXPECT_LE(result["skew_us"]["max"].get<int64_t>(), 1000) << result["skew_us"].dump();
  std::printf("one camlabd, 3 cameras: %d complete rig views, worst skew %lld us\n",
              views["complete"].get<int>(), static_cast<long long>(worst_us));
  EXPECT_LE(worst_us, 1000) << "one host, one frame clock";
  ASSERT_EQ(result["cameras"].size(), 3u);
  for (const json& c : result["cameras"]) EXPECT_EQ(c["state"], "succeeded") << c.dump();
  // The capture is a rig calibration's source (accepted; not run to the end here).
  auto calibration =
      daemon.post("/v1/calibrations",
                  {{"rig_capture", capture}, {"inner_corners", {14, 10}}, {"spacing_m", 0.04}});
  ASSERT_EQ(calibration.status, 202) << calibration.body;
  (void)daemon.del("/v1/jobs/" + std::to_string(calibration.json()["id"].get<int64_t>()));
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
  fs::remove_all(dir);
}
