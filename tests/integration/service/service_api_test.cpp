// camlabd end to end with in-process virtual cameras: every endpoint, auth, malformed and
// oversized requests, out-of-range controls, cancel, the OpenAPI document against the
// router, and each injected device fault. One daemon (started once) serves the suite;
// each test uses its own camera where a fault could leave it broken.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "daemon_harness.h"
#include "service/api/router.h"
#include "service/api/service_context.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

class ServiceApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fresh_test_dir("api"));
    write_test_specs(*dir_);
    daemon_ = new Daemon();
    // 4 cameras: 0 for the API, 1 fail_next_dequeues, 2 drop/stall, 3 unplug.
    started_ =
        daemon_->start(*dir_, {"--no-scan", "--camera-spec", (*dir_ / "camera.json").string(),
                               "--scene", (*dir_ / "scene.json").string(), "--virtual-count", "4",
                               "--test-faults", "--frame-timeout-ms", "1500", "--max-body-bytes",
                               "65536", "--max-header-bytes", "4096", "--max-queued-jobs", "4"});
    if (started_) {
      const json list = daemon_->get("/v1/cameras").json();
      for (const auto& c : list["cameras"]) cameras_.push_back(c["id"]);
    }
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0) << daemon_->log();
    }
    delete daemon_;
    fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    ASSERT_TRUE(started_) << (daemon_ ? daemon_->log() : "");
    ASSERT_EQ(cameras_.size(), 4u) << daemon_->get("/v1/cameras").body << daemon_->log();
  }
  static std::string camera_path(int i) { return "/v1/cameras/" + url_segment(cameras_[i]); }
  // Queues a capture and returns its job id (or -1).
  static int64_t capture(int camera, const json& request) {
    auto r = daemon_->post(camera_path(camera) + "/captures", request);
    EXPECT_EQ(r.status, 202) << r.body;
    return r.status == 202 ? r.json()["id"].get<int64_t>() : -1;
  }
  static json wait_frames(int64_t id, int frames) {
    return daemon_->wait_job(id, [frames](const json& j) {
      return j["progress"]["frames_done"].get<int>() >= frames ||
             (j["state"] != "queued" && j["state"] != "running");
    });
  }

  static inline fs::path* dir_ = nullptr;
  static inline Daemon* daemon_ = nullptr;
  static inline bool started_ = false;
  static inline std::vector<std::string> cameras_;
};

TEST_F(ServiceApi, HealthIsPublicAndEverythingElseNeedsTheToken) {
  auto health = http(daemon_->port(), "GET", "/v1/health");
  EXPECT_EQ(health.status, 200);
  EXPECT_EQ(health.json()["status"], "ok");
  for (const auto& [method, path] :
       std::vector<std::pair<std::string, std::string>>{{"GET", "/v1/cameras"},
                                                        {"GET", "/metrics"},
                                                        {"GET", "/v1/openapi.json"},
                                                        {"GET", "/v1/jobs"},
                                                        {"GET", "/v1/jobs/1"},
                                                        {"DELETE", "/v1/jobs/1"},
                                                        {"POST", "/v1/calibrations"},
                                                        {"GET", "/v1/nothing"}}) {
    auto none = http(daemon_->port(), method, path);
    EXPECT_EQ(none.status, 401) << method << " " << path;
    EXPECT_EQ(none.error_code(), "unauthorized");
    auto wrong = http(daemon_->port(), method, path, std::string(daemon_->token().size(), 'a'));
    EXPECT_EQ(wrong.status, 401) << method << " " << path;
  }
  const auto mode = fs::status(*dir_ / "data" / "token").permissions();
  EXPECT_EQ(mode & (fs::perms::group_all | fs::perms::others_all), fs::perms::none);
}

TEST_F(ServiceApi, ListsAndDescribesCamerasWithRangesAndUnits) {
  auto list = daemon_->get("/v1/cameras");
  ASSERT_EQ(list.status, 200);
  EXPECT_EQ(list.json()["cameras"].size(), 4u);
  auto one = daemon_->get(camera_path(0));
  ASSERT_EQ(one.status, 200) << one.body;
  const json camera = one.json();
  EXPECT_EQ(camera["id"], cameras_[0]);
  EXPECT_TRUE(camera["available"].get<bool>());
  bool exposure = false;
  for (const auto& c : camera["controls"])
    if (c["name"] == "exposure_time_absolute") {
      exposure = true;
      EXPECT_EQ(c["min"], 1);
      EXPECT_EQ(c["max"], 200);
      EXPECT_EQ(c["unit"], "100 us");
    }
  EXPECT_TRUE(exposure) << camera.dump();
  EXPECT_FALSE(camera["formats"].empty());
  EXPECT_EQ(daemon_->get("/v1/cameras/v4l2%3Anope").status, 404);
  EXPECT_EQ(daemon_->get("/v1/cameras/%2e%2e%2Fetc").status,
            400);  // an encoded '/' never becomes a path
}

TEST_F(ServiceApi, ControlsAreSetAndOutOfRangeValuesGet422NamingTheRange) {
  auto ok = daemon_->put(camera_path(0) + "/controls", {{"exposure_time_absolute", 40}});
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(ok.json()["controls"]["exposure_time_absolute"]["applied"], 40);
  auto high = daemon_->put(camera_path(0) + "/controls", {{"exposure_time_absolute", 5000}});
  EXPECT_EQ(high.status, 422) << high.body;
  EXPECT_EQ(high.error_code(), "out_of_range");
  EXPECT_NE(high.json()["error"]["message"].get<std::string>().find("[1, 200]"), std::string::npos)
      << high.body;
  auto unknown = daemon_->put(camera_path(0) + "/controls", {{"warp_drive", 1}});
  EXPECT_EQ(unknown.status, 422);
  auto typed = daemon_->put(camera_path(0) + "/controls", {{"gain", "loud"}});
  EXPECT_EQ(typed.status, 400);
  // The camera reports what was applied.
  const json after = daemon_->get(camera_path(0)).json();
  for (const auto& c : after["controls"]) {
    if (c["name"] == "exposure_time_absolute") {
      EXPECT_EQ(c["current"], 40);
    }
  }
}

// The review's "late validation" findings: each of these was accepted before.
TEST_F(ServiceApi, AmbiguousRequestsAreRefusedWhenSubmittedNotLater) {
  const int port = daemon_->port();
  // An unknown lens model: 202 and a failed job 51 s later, before.
  auto unknown_model = daemon_->post(
      "/v1/calibrations",
      {{"inner_corners", {14, 10}}, {"spacing_m", 0.04}, {"model", "LENSMODEL_OPENCV7"}});
  EXPECT_EQ(unknown_model.status, 422) << unknown_model.body;
  EXPECT_EQ(unknown_model.error_code(), "bad_lensmodel") << unknown_model.body;
  // A known one passes this check (and fails later on the missing source, as before).
  auto known_model =
      daemon_->post("/v1/calibrations", {{"inner_corners", {14, 10}},
                                         {"spacing_m", 0.04},
                                         {"model", "LENSMODEL_SPLINED_STEREOGRAPHIC"}});
  EXPECT_NE(known_model.error_code(), "bad_lensmodel") << known_model.body;
  // The same key twice: the parser kept the last one.
  auto duplicate = http(port, "POST", camera_path(0) + "/captures", daemon_->token(),
                        R"({"kind": "single", "repeats": 2, "repeats": 90})");
  EXPECT_EQ(duplicate.status, 400) << duplicate.body;
  EXPECT_EQ(duplicate.error_code(), "bad_json");
  EXPECT_NE(duplicate.body.find("repeats"), std::string::npos) << duplicate.body;
  auto nested_duplicate = http(port, "POST", camera_path(0) + "/captures", daemon_->token(),
                               R"({"kind": "single", "x": {"a": 1, "a": 2}})");
  EXPECT_EQ(nested_duplicate.error_code(), "bad_json") << nested_duplicate.body;
  // The same key in two different objects is no duplicate.
  auto distinct = http(port, "POST", camera_path(0) + "/captures", daemon_->token(),
                       R"({"kind": "timelapse", "x": {"kind": 1}})");
  EXPECT_NE(distinct.error_code(), "bad_json") << distinct.body;
  // A UTF-8 byte order mark before the JSON.
  auto bom = http(port, "POST", camera_path(0) + "/captures", daemon_->token(),
                  "\xEF\xBB\xBF{\"kind\": \"single\"}");
  EXPECT_EQ(bom.status, 400) << bom.body;
  EXPECT_EQ(bom.error_code(), "bad_json");
  // A request target that is not a path.
  for (const char* target : {"v1/health", "http://127.0.0.1/v1/health", "*"}) {
    auto r = http(port, "GET", target);
    EXPECT_EQ(r.status, 400) << target << ": " << r.body;
  }
  EXPECT_EQ(http(port, "GET", "/v1/health").status, 200);
}

TEST_F(ServiceApi, MalformedAndOversizedRequestsGet4xxAndTheDaemonKeepsServing) {
  const int port = daemon_->port();
  auto bad_json = http(port, "POST", camera_path(0) + "/captures", daemon_->token(), "{\"kind\": ");
  EXPECT_EQ(bad_json.status, 400);
  EXPECT_EQ(bad_json.error_code(), "bad_json");
  auto not_object = http(port, "POST", camera_path(0) + "/captures", daemon_->token(), "[1, 2]");
  EXPECT_EQ(not_object.status, 400);
  auto bad_kind = daemon_->post(camera_path(0) + "/captures", {{"kind", "timelapse"}});
  EXPECT_EQ(bad_kind.status, 400) << bad_kind.body;
  auto out_of_range = daemon_->post(camera_path(0) + "/captures",
                                    {{"kind", "bracket"}, {"exposures_us", {1000, 900000}}});
  EXPECT_EQ(out_of_range.status, 422) << out_of_range.body;
  auto garbage = raw_exchange(port, "THIS IS NOT HTTP\r\n\r\n");
  EXPECT_EQ(garbage.status, 400);
  const std::string big_body(200000, ' ');
  auto big = http(port, "POST", camera_path(0) + "/captures", daemon_->token(), big_body);
  EXPECT_EQ(big.status, 413);
  auto big_header = raw_exchange(
      port, "GET /v1/health HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'x') + "\r\n\r\n");
  EXPECT_EQ(big_header.status, 431);
  EXPECT_EQ(daemon_->get("/v1/jobs/abc").status, 400);
  EXPECT_EQ(daemon_->get("/v1/jobs/99999999999999999999").status, 400);
  EXPECT_EQ(daemon_->get("/v1/jobs/424242").status, 404);
  EXPECT_EQ(daemon_->get("/v1/jobs?limit=0").status, 400);
  EXPECT_EQ(daemon_->get("/v1/jobs?state=sleeping").status, 400);
  EXPECT_EQ(http(port, "PATCH", "/v1/jobs", daemon_->token()).status, 405);
  EXPECT_EQ(http(port, "GET", "/v1/health").status, 200) << "the daemon still serves";
}

TEST_F(ServiceApi, CaptureJobRunsAndItsFramesDownloadAsPngWithSidecars) {
  const int64_t id =
      capture(0, {{"kind", "bracket"}, {"exposures_us", {1000, 2000}}, {"repeats", 2}});
  ASSERT_GT(id, 0);
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_EQ(job["progress"]["frames_done"], 4);
  EXPECT_GE(job["result"]["frames_consumed"].get<int>(), 4 + 3);
  auto frames = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames");
  ASSERT_EQ(frames.status, 200);
  EXPECT_TRUE(frames.json()["complete"].get<bool>());
  ASSERT_EQ(frames.json()["frames"].size(), 4u);
  auto png = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/3");
  ASSERT_EQ(png.status, 200);
  EXPECT_EQ(png.headers["content-type"], "image/png");
  cv::Mat image =
      cv::imdecode(std::vector<uchar>(png.body.begin(), png.body.end()), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(image.cols, 160);
  EXPECT_EQ(image.rows, 120);
  auto meta = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/3/meta");
  ASSERT_EQ(meta.status, 200);
  EXPECT_DOUBLE_EQ(meta.json()["settings"]["exposure_us"].get<double>(), 2000.0) << meta.body;
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/4").status, 404);
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/-1").status, 400);
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/..%2Fmanifest.json").status,
            400);
  auto list = daemon_->get("/v1/jobs?state=succeeded&limit=5");
  ASSERT_EQ(list.status, 200);
  EXPECT_FALSE(list.json()["jobs"].empty());
  EXPECT_EQ(daemon_->del("/v1/jobs/" + std::to_string(id)).status, 409)
      << "finished jobs cannot be cancelled";
}

TEST_F(ServiceApi, CancelStopsARunningCaptureKeepingItsFramesAndCancelsAQueuedOne) {
  const int64_t running =
      capture(0, {{"kind", "bracket"}, {"exposures_us", {1000, 2000}}, {"repeats", 50}});
  const int64_t queued = capture(0, {{"kind", "single"}});
  ASSERT_GT(running, 0);
  ASSERT_GT(queued, 0);
  EXPECT_GE(wait_frames(running, 2)["progress"]["frames_done"].get<int>(), 2);
  auto cancel_queued = daemon_->del("/v1/jobs/" + std::to_string(queued));
  EXPECT_EQ(cancel_queued.status, 200) << cancel_queued.body;
  EXPECT_EQ(cancel_queued.json()["state"], "cancelled");
  auto cancel = daemon_->del("/v1/jobs/" + std::to_string(running));
  EXPECT_EQ(cancel.status, 202) << cancel.body;
  const json job = daemon_->wait_finished(running);
  EXPECT_EQ(job["state"], "cancelled") << job.dump();
  auto frames = daemon_->get("/v1/jobs/" + std::to_string(running) + "/frames").json();
  EXPECT_GE(frames["frames"].size(), 2u);
  EXPECT_LT(frames["frames"].size(), 100u);
  EXPECT_FALSE(frames["complete"].get<bool>());
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(running) + "/frames/1").status, 200);
}

TEST_F(ServiceApi, TooManyQueuedJobsGet429) {
  std::vector<int64_t> ids;
  int rejected = 0;
  for (int i = 0; i < 8; ++i) {
    auto r = daemon_->post(camera_path(0) + "/captures", {{"kind", "single"}, {"repeats", 20}});
    if (r.status == 202) ids.push_back(r.json()["id"]);
    if (r.status == 429) ++rejected;
  }
  EXPECT_GT(rejected, 0);
  for (int64_t id : ids) daemon_->del("/v1/jobs/" + std::to_string(id));
  for (int64_t id : ids) daemon_->wait_finished(id);
}

// The review's finding: after cancelling every queued job, the next capture still got 429
// until the running job ended, because the worker's queue kept the cancelled jobs' slots.
TEST_F(ServiceApi, CancelledQueuedJobsGiveTheirQueueSlotsBackAtOnce) {
  const int64_t running = capture(0, {{"kind", "single"}, {"repeats", 300}});
  ASSERT_GT(running, 0);
  ASSERT_GE(wait_frames(running, 1)["progress"]["frames_done"].get<int>(), 1);  // out of the queue
  std::vector<int64_t> queued;
  for (int i = 0; i < 8; ++i) {  // the queue takes 4 (--max-queued-jobs)
    auto r = daemon_->post(camera_path(0) + "/captures", {{"kind", "single"}});
    if (r.status != 202) {
      EXPECT_EQ(r.status, 429) << r.body;
      break;
    }
    queued.push_back(r.json()["id"]);
  }
  ASSERT_FALSE(queued.empty());
  for (int64_t id : queued) {
    auto cancel = daemon_->del("/v1/jobs/" + std::to_string(id));
    EXPECT_EQ(cancel.status, 200) << cancel.body;
  }
  ASSERT_EQ(daemon_->get("/v1/jobs/" + std::to_string(running)).json()["state"], "running")
      << "the test needs the first job still running";
  auto next = daemon_->post(camera_path(0) + "/captures", {{"kind", "single"}});
  EXPECT_EQ(next.status, 202) << next.body;
  daemon_->del("/v1/jobs/" + std::to_string(running));
  if (next.status == 202) {
    const json job = daemon_->wait_finished(next.json()["id"]);
    EXPECT_EQ(job["state"], "succeeded") << job.dump();
  }
  daemon_->wait_finished(running);
}

// A frame file replaced by a symlink (here to the API token) must not be followed when
// frames are served: the review got the token back as "frame 0".
TEST_F(ServiceApi, AFrameReplacedBySymlinkIsNotFollowed) {
  const int64_t id = capture(0, {{"kind", "single"}, {"repeats", 2}});
  ASSERT_GT(id, 0);
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const fs::path folder = *dir_ / "data" / job["folder"].get<std::string>();
  const json frames = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames").json();
  ASSERT_GE(frames["frames"].size(), 2u) << frames.dump();
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/1").status, 200);
  // Frame 0's image and sidecar become symlinks to the token.
  int replaced = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("frame_000000", 0) != 0) continue;
    fs::remove(entry.path());
    fs::create_symlink(*dir_ / "data" / "token", entry.path());
    ++replaced;
  }
  ASSERT_EQ(replaced, 2);
  for (const char* suffix : {"", "/meta"}) {
    auto r = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/0" + suffix);
    EXPECT_NE(r.status, 200) << suffix << ": " << r.body;
    EXPECT_EQ(r.body.find(daemon_->token()), std::string::npos) << "the token was served";
  }
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/1").status, 200);
}

// A job folder replaced by a symlink (the second review) was followed: a link to another
// capture folder served that folder's frames as this job's. Not any more.
TEST_F(ServiceApi, AJobFolderReplacedBySymlinkIsNotFollowed) {
  const int64_t first = capture(0, {{"kind", "single"}, {"repeats", 2}});
  const int64_t second = capture(0, {{"kind", "single"}, {"repeats", 3}});
  ASSERT_GT(first, 0);
  ASSERT_GT(second, 0);
  const json a = daemon_->wait_finished(first);
  const json b = daemon_->wait_finished(second);
  ASSERT_EQ(a["state"], "succeeded") << a.dump();
  ASSERT_EQ(b["state"], "succeeded") << b.dump();
  const std::string frames = "/v1/jobs/" + std::to_string(first) + "/frames";
  ASSERT_EQ(daemon_->get(frames + "/0").status, 200);
  // The first job's folder becomes a link to the second's (elsewhere it could be /etc).
  const fs::path folder = *dir_ / "data" / a["folder"].get<std::string>();
  fs::rename(folder, fs::path(folder.string() + ".moved"));
  fs::create_symlink(*dir_ / "data" / b["folder"].get<std::string>(), folder);
  for (const std::string& path : {frames, frames + "/0", frames + "/0/meta"}) {
    auto r = daemon_->get(path);
    EXPECT_EQ(r.status, 404) << path << ": " << r.body;
  }
}

// Error messages name files relative to the data folder: the server's absolute paths
// are not the client's business (the review saw them in errors).
TEST_F(ServiceApi, ErrorsNameFilesRelativeToTheDataFolder) {
  const int64_t id = capture(0, {{"kind", "single"}, {"repeats", 1}});
  ASSERT_GT(id, 0);
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const std::string folder = job["folder"].get<std::string>();
  std::ofstream(*dir_ / "data" / folder / "manifest.json") << "{ not json";
  auto r = daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames");
  EXPECT_GE(r.status, 400) << r.body;
  const std::string absolute = fs::canonical(*dir_ / "data").string();
  EXPECT_EQ(r.body.find(absolute), std::string::npos) << r.body;
  EXPECT_NE(r.body.find(folder), std::string::npos) << "names the folder: " << r.body;
}

// The OpenAPI document and the validators must not drift (the review found exposure_us,
// label and the repeats maximum missing): every field the capture validator accepts, for
// every kind, is a documented property of CaptureRequest, and the documented maximum of
// repeats is the one the validator enforces.
TEST_F(ServiceApi, TheOpenApiCaptureSchemaListsEveryFieldTheValidatorAccepts) {
  const json doc = daemon_->get("/v1/openapi.json").json();
  const json& properties = doc["components"]["schemas"]["CaptureRequest"]["properties"];
  ASSERT_TRUE(properties.is_object()) << doc.dump().substr(0, 500);
  for (const char* kind : {"single", "bracket", "focus_stack", "aperture_series"}) {
    auto r = daemon_->post(camera_path(0) + "/captures", {{"kind", kind}, {"zz_not_a_field", 1}});
    ASSERT_EQ(r.status, 400) << r.body;
    const std::string message = r.json()["error"]["message"];
    const size_t at = message.find("(allowed: ");
    ASSERT_NE(at, std::string::npos) << message;
    std::string list = message.substr(at + 10, message.find(')', at) - at - 10);
    int fields = 0;
    for (size_t start = 0; start < list.size();) {
      size_t end = list.find(", ", start);
      if (end == std::string::npos) end = list.size();
      const std::string field = list.substr(start, end - start);
      EXPECT_TRUE(properties.contains(field)) << kind << ": '" << field << "' is undocumented";
      ++fields;
      start = end + 2;
    }
    EXPECT_GE(fields, 7) << message;
  }
  const int maximum = properties["repeats"]["maximum"].get<int>();
  EXPECT_EQ(
      daemon_->post(camera_path(0) + "/captures", {{"kind", "single"}, {"repeats", maximum + 1}})
          .status,
      400);
}

TEST_F(ServiceApi, LatencyProbeMeasuresTheSpecsThreeFramesAndStoresIt) {
  auto r = daemon_->post(camera_path(0) + "/latency-probe", json::object());
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon_->wait_finished(r.json()["id"]);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_EQ(job["result"]["details"]["probed_frames"], 3) << job.dump();
  EXPECT_EQ(daemon_->get(camera_path(0)).json()["control_latency"]["frames"], 3);
}

// The review found two metrics disagreeing with the job states: a job cancelled while
// queued was never counted as finished, and a job cancelled while running was counted with
// the outcome it computed rather than the state stored. Now every finished (kind, state)
// counter equals the number of this daemon's jobs the API lists with that kind and state,
// and camlabd_jobs{state} equals the listing's count per state.
TEST_F(ServiceApi, JobMetricsAgreeWithTheJobStates) {
  const int64_t running = capture(0, {{"kind", "single"}, {"repeats", 60}});
  const int64_t queued = capture(0, {{"kind", "single"}});
  ASSERT_EQ(daemon_->del("/v1/jobs/" + std::to_string(queued)).status, 200);
  (void)daemon_->del("/v1/jobs/" + std::to_string(running));
  daemon_->wait_finished(running);
  const int64_t done = capture(1, {{"kind", "single"}});
  ASSERT_EQ(daemon_->wait_finished(done)["state"], "succeeded");
  // Every job of this daemon, finished.
  std::map<std::pair<std::string, std::string>, int64_t> listed;
  std::map<std::string, int64_t> listed_by_state;
  for (int offset = 0;; offset += 100) {
    const json page =
        daemon_->get("/v1/jobs?limit=100&offset=" + std::to_string(offset)).json()["jobs"];
    for (const auto& job : page) {
      json j = job;
      if (j["state"] == "queued" || j["state"] == "running")
        j = daemon_->wait_finished(j["id"].get<int64_t>());
      ++listed[{j["kind"], j["state"]}];
      ++listed_by_state[j["state"]];
    }
    if (page.size() < 100) break;
  }
  const std::string metrics = daemon_->get("/metrics").body;
  auto value_of = [&](const std::string& series) -> int64_t {
    const size_t at = metrics.find(series + " ");
    return at == std::string::npos ? 0 : std::stoll(metrics.substr(at + series.size() + 1));
  };
  const std::pair<std::string, std::string> cancelled_capture{"capture", "cancelled"};
  ASSERT_GE(listed[cancelled_capture], 1) << metrics;
  for (const auto& [key, count] : listed)
    EXPECT_EQ(value_of("camlabd_jobs_finished_total{kind=\"" + key.first + "\",state=\"" +
                       key.second + "\"}"),
              count)
        << key.first << " " << key.second << "\n"
        << metrics;
  for (const auto& [state, count] : listed_by_state)
    EXPECT_EQ(value_of("camlabd_jobs{state=\"" + state + "\"}"), count) << state;
}

// GET /v1/jobs/{id}?wait=S: one request waits for the job to finish (the README's session
// typed line by line needs no polling loop); a short wait answers with the job still
// running; a bad wait is refused.
TEST_F(ServiceApi, JobLongPollAnswersOnceTheJobHasFinished) {
  const int64_t id = capture(0, {{"kind", "single"}, {"repeats", 10}});
  auto r = daemon_->get("/v1/jobs/" + std::to_string(id) + "?wait=60");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "succeeded") << r.body;
  EXPECT_EQ(r.json()["progress"]["frames_done"], 10);

  const int64_t long_id = capture(0, {{"kind", "single"}, {"repeats", 300}});
  auto early = daemon_->get("/v1/jobs/" + std::to_string(long_id) + "?wait=0.3");
  ASSERT_EQ(early.status, 200) << early.body;
  const std::string state = early.json()["state"];
  EXPECT_TRUE(state == "queued" || state == "running") << early.body;
  for (const char* bad : {"abc", "61", "-1", "", "1e400", "nan"})
    EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(long_id) + "?wait=" + bad).status, 400)
        << bad;
  EXPECT_EQ(daemon_->get("/v1/jobs/999999?wait=1").status, 404);
  (void)daemon_->del("/v1/jobs/" + std::to_string(long_id));
  EXPECT_NE(daemon_->get("/v1/jobs/" + std::to_string(long_id) + "?wait=60").json()["state"],
            "running");
}

TEST_F(ServiceApi, MetricsCountRequestsFramesAndJobs) {
  ASSERT_EQ(daemon_->get(camera_path(0)).status, 200);
  const int64_t id = capture(0, {{"kind", "single"}, {"repeats", 2}});
  ASSERT_EQ(daemon_->wait_finished(id)["state"], "succeeded");
  auto r = daemon_->get("/metrics");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.headers["content-type"].rfind("text/plain", 0), 0u);
  for (const char* name : {"camlabd_http_requests_total{", "camlabd_jobs{state=\"succeeded\"}",
                           "camlabd_frames_captured_total ", "camlabd_frames_discarded_total "})
    EXPECT_NE(r.body.find(name), std::string::npos) << name << "\n" << r.body;
  EXPECT_NE(r.body.find("route=\"/v1/cameras/{id}\""), std::string::npos)
      << "counted by route pattern, not path";
  EXPECT_EQ(r.body.find("camlabd_frames_captured_total 0\n"), std::string::npos) << r.body;
}

// The OpenAPI document lists exactly the router's routes, and every documented route
// answers (no 404 "no_route" / 405).
TEST_F(ServiceApi, OpenApiDocumentMatchesTheRoutes) {
  auto r = daemon_->get("/v1/openapi.json");
  ASSERT_EQ(r.status, 200);
  const json doc = r.json();
  EXPECT_EQ(doc["openapi"].get<std::string>().rfind("3.", 0), 0u);
  std::set<std::string> documented;
  for (const auto& [path, ops] : doc["paths"].items())
    for (const auto& [method, op] : ops.items()) {
      std::string m = method;
      std::transform(m.begin(), m.end(), m.begin(), ::toupper);
      documented.insert(m + " " + path);
    }
  camlab::service::ServiceContext context;
  context.test_faults = true;
  camlab::service::Router router(nullptr, nullptr);
  camlab::service::add_all_routes(router, context);
  std::set<std::string> routed;
  for (const auto& route : router.routes()) routed.insert(route.method + " " + route.pattern);
  EXPECT_EQ(documented, routed);
  EXPECT_TRUE(doc["paths"]["/v1/test/cameras/{id}/faults"]["post"].value("x-test-only", false));
  // The review: no additionalProperties: false, no limits, no 503/504. Request bodies with
  // a field the handler does not know are refused (400), and the schemas say so; the limits
  // are calib/calibration_request.h's; every operation can answer 503 and 504.
  for (const char* name : {"CalibrationRequest", "CalibrationSessionRequest", "AnalysisRequest"})
    EXPECT_EQ(doc["components"]["schemas"][name]["additionalProperties"], false) << name;
  const json& calibration = doc["components"]["schemas"]["CalibrationRequest"]["properties"];
  EXPECT_EQ(calibration["spacing_m"]["minimum"], 1e-6);
  EXPECT_EQ(calibration["inner_corners"]["items"]["maximum"], 100);
  for (const auto& [path, ops] : doc["paths"].items())
    for (const auto& [method, op] : ops.items()) {
      EXPECT_TRUE(op["responses"].contains("503")) << method << " " << path;
      EXPECT_TRUE(op["responses"].contains("504")) << method << " " << path;
    }
  for (const char* route : {"/v1/calibrations", "/v1/analyses"}) {
    auto typo = daemon_->post(route, {{"kind", "exposure"}, {"job", 1}, {"inner_corner", {9, 6}}});
    EXPECT_EQ(typo.status, 400) << route << ": " << typo.body;
    EXPECT_NE(typo.body.find("inner_corner"), std::string::npos) << typo.body;
  }
  EXPECT_FALSE(
      camlab::service::openapi_document(false)["paths"].contains("/v1/test/cameras/{id}/faults"));
  for (const auto& entry : documented) {
    const std::string method = entry.substr(0, entry.find(' '));
    std::string path = entry.substr(entry.find(' ') + 1);
    for (auto [from, to] : {std::pair<std::string, std::string>{"{id}", "999999"}, {"{n}", "0"}})
      for (size_t at; (at = path.find(from)) != std::string::npos;)
        path.replace(at, from.size(), to);
    auto answer = http(daemon_->port(), method, path, daemon_->token(),
                       method == "GET" || method == "DELETE" ? "" : "{}");
    EXPECT_NE(answer.status, 0) << entry;
    EXPECT_NE(answer.error_code(), "no_route") << entry;
    EXPECT_NE(answer.status, 405) << entry;
  }
}

TEST_F(ServiceApi, DequeueErrorsFailTheJobKeepingFramesAndTheCameraRecovers) {
  const int64_t id = capture(1, {{"kind", "single"}, {"repeats", 40}});
  ASSERT_GT(id, 0);
  EXPECT_GE(wait_frames(id, 2)["progress"]["frames_done"].get<int>(), 2);
  auto fault = daemon_->post("/v1/test/cameras/" + url_segment(cameras_[1]) + "/faults",
                             {{"fail_next_dequeues", 1}});
  ASSERT_EQ(fault.status, 200) << fault.body;
  const json job = daemon_->wait_finished(id);
  EXPECT_EQ(job["state"], "failed") << job.dump();
  EXPECT_FALSE(job["error"]["message"].get<std::string>().empty());
  const int kept = job["progress"]["frames_done"];
  EXPECT_GE(kept, 2);
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames").json()["frames"].size(),
            static_cast<size_t>(kept));
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/0").status, 200);
  // The next job on the same camera works.
  const int64_t next = capture(1, {{"kind", "single"}});
  EXPECT_EQ(daemon_->wait_finished(next)["state"], "succeeded");
}

TEST_F(ServiceApi, DroppedFramesAreCountedAndTheSettingsStayFrameAccurate) {
  const int64_t id =
      capture(2, {{"kind", "bracket"}, {"exposures_us", {1000, 4000}}, {"repeats", 3}});
  ASSERT_GT(id, 0);
  daemon_->post("/v1/test/cameras/" + url_segment(cameras_[2]) + "/faults",
                {{"drop_next_frames", 4}});
  const json job = daemon_->wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  for (int i = 0; i < 6; ++i) {
    auto meta =
        daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/" + std::to_string(i) + "/meta")
            .json();
    EXPECT_DOUBLE_EQ(meta["settings"]["exposure_us"].get<double>(), i < 3 ? 1000.0 : 4000.0)
        << meta.dump();
  }
}

TEST_F(ServiceApi, AStalledCameraTimesOutTheJobAndServesAgainWhenItResumes) {
  daemon_->post("/v1/test/cameras/" + url_segment(cameras_[2]) + "/faults", {{"stall", true}});
  const int64_t id = capture(2, {{"kind", "single"}});
  const json job = daemon_->wait_finished(id);
  EXPECT_EQ(job["state"], "failed") << job.dump();
  EXPECT_EQ(job["error"]["code"], "timeout") << job.dump();
  EXPECT_EQ(http(daemon_->port(), "GET", "/v1/health").status, 200);
  daemon_->post("/v1/test/cameras/" + url_segment(cameras_[2]) + "/faults", {{"stall", false}});
  const int64_t next = capture(2, {{"kind", "single"}});
  EXPECT_EQ(daemon_->wait_finished(next)["state"], "succeeded");
}

TEST_F(ServiceApi, AnUnpluggedCameraLosesItsJobKeepsFramesAndTheOthersKeepCapturing) {
  const int64_t id = capture(3, {{"kind", "single"}, {"repeats", 60}});
  ASSERT_GT(id, 0);
  const int64_t other =
      capture(0, {{"kind", "single"}, {"repeats", 3}});  // in parallel on camera 0
  EXPECT_GE(wait_frames(id, 2)["progress"]["frames_done"].get<int>(), 2);
  ASSERT_EQ(
      daemon_->post("/v1/test/cameras/" + url_segment(cameras_[3]) + "/faults", {{"unplug", true}})
          .status,
      200);
  const json job = daemon_->wait_finished(id);
  EXPECT_EQ(job["state"], "device_lost") << job.dump();
  EXPECT_EQ(job["error"]["code"], "device_lost") << job.dump();
  EXPECT_GE(job["progress"]["frames_done"].get<int>(), 2);
  EXPECT_EQ(daemon_->get("/v1/jobs/" + std::to_string(id) + "/frames/1").status, 200);
  EXPECT_EQ(daemon_->wait_finished(other)["state"], "succeeded");
  EXPECT_FALSE(daemon_->get(camera_path(3)).json()["available"].get<bool>());
  auto refused = daemon_->post(camera_path(3) + "/captures", {{"kind", "single"}});
  EXPECT_EQ(refused.status, 503) << refused.body;
  EXPECT_EQ(daemon_->post("/v1/test/cameras/" + url_segment(cameras_[3]) + "/faults", {{"warp", 1}})
                .status,
            400);
}

}  // namespace
