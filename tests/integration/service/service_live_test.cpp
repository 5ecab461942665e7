// The dashboard's API end to end on the built camlabd (docs/dashboard.md): the live view
// stream, the histogram of raw DN against the sensor's physics, server-sent events, frame
// thumbnails and the plots of analysis jobs, and how each refuses bad input or ends when
// its camera goes. The test camera is noise-free (daemon_harness.h), so the histogram's
// mean above black is exactly proportional to the exposure.
#include <gtest/gtest.h>

#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <thread>
#include <vector>

#include "capture_checks.h"
#include "daemon_harness.h"
#include "stream_client.h"

namespace camlab::testing {
namespace {

using nlohmann::json;

class ServiceLive : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_test_dir(
        "live_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    write_test_specs(dir_);
    ASSERT_TRUE(daemon_.start(dir_, {"--no-scan", "--camera-spec", (dir_ / "camera.json").string(),
                                     "--scene", (dir_ / "scene.json").string(), "--test-faults"}))
        << daemon_.log();
    camera_ = "/v1/cameras/" + url_segment(daemon_.camera_id());
    // The start-up latency probe first, so that frames flow when a test asks.
    for (int i = 0; i < 200 && daemon_.get(camera_).json().value("measuring_latency", true); ++i)
      std::this_thread::sleep_for(50ms);
  }
  void TearDown() override {
    EXPECT_EQ(daemon_.stop(), 0) << daemon_.log();
    fs::remove_all(dir_);
  }

  static cv::Mat decode(const std::string& bytes) {
    return cv::imdecode(
        cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
        cv::IMREAD_UNCHANGED);
  }

  json histogram() const { return daemon_.get(camera_ + "/histogram?bins=1024").json(); }

  fs::path dir_;
  Daemon daemon_;
  std::string camera_;
};

TEST_F(ServiceLive, TheLiveViewSendsNewerFramesAtMostAtItsCapAndRunsBesideACapture) {
  StreamClient live;
  ASSERT_TRUE(live.open(daemon_.port(), camera_ + "/live?fps=5&width=80", daemon_.token()));
  ASSERT_EQ(live.status(), 200);
  EXPECT_EQ(live.header("content-type"), "multipart/x-mixed-replace; boundary=camlabframe");
  EXPECT_EQ(live.header("content-length"), "");  // the body ends with the connection

  const auto start = std::chrono::steady_clock::now();
  int frames = 0;
  long last_sequence = -1;
  while (std::chrono::steady_clock::now() - start < 2s) {
    auto part = live.next_part(5s);
    ASSERT_TRUE(part) << "the stream stopped";
    EXPECT_EQ(part->headers["content-type"], "image/jpeg");
    const long sequence = std::atol(part->headers["x-frame-sequence"].c_str());
    EXPECT_GT(sequence, last_sequence);
    last_sequence = sequence;
    const cv::Mat image = decode(part->body);
    ASSERT_FALSE(image.empty());
    EXPECT_EQ(image.cols, 80);  // 160 x 120 scaled to the width asked
    EXPECT_EQ(image.rows, 60);
    ++frames;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LE(frames, 2 + static_cast<int>(5 * seconds));  // the cap is an upper bound

  // A capture on the same camera: it keeps all its frames, and the viewer keeps getting
  // frames while it runs (from the capture's own stream).
  auto posted = daemon_.post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 100}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t id = posted.json()["id"];
  int during = 0;
  std::string state = "queued";
  for (int i = 0; i < 600 && (state == "queued" || state == "running"); ++i) {
    auto part = live.next_part(5s);
    ASSERT_TRUE(part);
    const std::string now = daemon_.get("/v1/jobs/" + std::to_string(id)).json().value("state", "");
    if (state == "running" && now == "running") ++during;
    state = now;
  }
  const json job = daemon_.wait_finished(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_EQ(job["result"]["frames_kept"], 100);
  EXPECT_GE(during, 3) << "the live view paused during the capture";
}

TEST_F(ServiceLive, TheHistogramOfRawDnFollowsTheExposureAsTheSensorIsLinear) {
  auto first = histogram();
  ASSERT_TRUE(first.contains("channels")) << first.dump();
  EXPECT_EQ(first["bit_depth"], 10);
  EXPECT_EQ(first["black_level_dn"], 32);
  EXPECT_EQ(first["white_level_dn"], 1023);
  EXPECT_EQ(first["bin_width_dn"], 1);
  ASSERT_EQ(first["channels"].size(), 1u);
  const json& y = first["channels"][0];
  EXPECT_EQ(y["channel"], "Y");
  EXPECT_EQ(y["samples"], 160 * 120);
  uint64_t total = 0, weighted = 0;
  for (size_t dn = 0; dn < y["counts"].size(); ++dn) {
    total += y["counts"][dn].get<uint64_t>();
    weighted += dn * y["counts"][dn].get<uint64_t>();
  }
  EXPECT_EQ(total, 160u * 120u);
  EXPECT_NEAR(static_cast<double>(weighted) / total, y["mean_dn"].get<double>(), 1e-9);

  // Exposure 10 -> 20 (x 100 us): the signal above black doubles, within quantisation.
  ASSERT_EQ(daemon_.put(camera_ + "/controls", {{"exposure_time_absolute", 10}}).status, 200);
  auto mean_after = [&](int exposure) {
    EXPECT_EQ(daemon_.put(camera_ + "/controls", {{"exposure_time_absolute", exposure}}).status,
              200);
    // The change reaches the frames after the control latency; the value then holds.
    double mean = 0, previous = -1;
    for (int i = 0; i < 40; ++i) {
      mean = histogram()["channels"][0]["mean_dn"].get<double>();
      if (std::abs(mean - previous) < 0.01) break;
      previous = mean;
    }
    return mean;
  };
  const double m10 = mean_after(10), m20 = mean_after(20);
  EXPECT_NEAR((m20 - 32) / (m10 - 32), 2.0, 0.01) << m10 << " -> " << m20;

  EXPECT_EQ(daemon_.get(camera_ + "/histogram?bins=0").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get(camera_ + "/histogram?bins=abc").error_code(), "invalid_request");
}

// The review: a closed event stream kept its slot until the next heartbeat failed to be
// written (14.6 s); with the 64 slots taken and closed, a new client got 503 meanwhile.
// Now a slot is freed when its client closes.
TEST_F(ServiceLive, AClosedEventStreamFreesItsSlotAtOnce) {
  constexpr int kSlots = 64;  // JobEvents::kMaxSubscribers
  std::vector<std::unique_ptr<StreamClient>> streams;
  for (int i = 0; i < kSlots; ++i) {
    auto s = std::make_unique<StreamClient>();
    ASSERT_TRUE(s->open(daemon_.port(), "/v1/events", daemon_.token())) << i;
    ASSERT_EQ(s->status(), 200) << i;
    ASSERT_TRUE(s->next_event(5s)) << i;  // the greeting: the stream is set up
    streams.push_back(std::move(s));
  }
  StreamClient refused;
  ASSERT_TRUE(refused.open(daemon_.port(), "/v1/events", daemon_.token()));
  EXPECT_EQ(refused.status(), 503);
  refused.close();
  streams.clear();  // every client closes
  // A new stream finds a slot within 2 s (the heartbeat is 15 s).
  int status = 0;
  for (int i = 0; i < 20 && status != 200; ++i) {
    std::this_thread::sleep_for(100ms);
    StreamClient again;
    if (again.open(daemon_.port(), "/v1/events", daemon_.token())) status = again.status();
  }
  EXPECT_EQ(status, 200);
}

TEST_F(ServiceLive, EventsShowAJobFromItsStartToItsEndInOrder) {
  StreamClient events;
  ASSERT_TRUE(events.open(daemon_.port(), "/v1/events", daemon_.token()));
  ASSERT_EQ(events.status(), 200);
  EXPECT_EQ(events.header("content-type"), "text/event-stream");
  auto greeting = events.next_event(5s);
  ASSERT_TRUE(greeting);
  EXPECT_NE(greeting->find("retry: 2000"), std::string::npos);

  auto posted = daemon_.post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 30}});
  ASSERT_EQ(posted.status, 202);
  const int64_t id = posted.json()["id"];
  const std::map<std::string, int> order = {{"queued", 0}, {"running", 1}, {"succeeded", 2}};
  int last_rank = -1, last_done = -1, events_seen = 0;
  json last = json::object();
  for (int i = 0; i < 200 && last.value("state", "") != "succeeded"; ++i) {
    auto block = events.next_event(10s);
    ASSERT_TRUE(block) << "no event";
    if (block->rfind(":", 0) == 0) continue;  // a comment (keep-alive)
    ASSERT_NE(block->find("event: job"), std::string::npos) << *block;
    const json data = json::parse(block->substr(block->find("data: ") + 6));
    if (data["id"] != id) continue;
    ++events_seen;
    ASSERT_TRUE(order.count(data["state"])) << data.dump();
    const int rank = order.at(data["state"]);
    EXPECT_GE(rank, last_rank) << "a job's state went back: " << data.dump();
    if (data["state"] == "running") {
      EXPECT_GE(data["frames_done"].get<int>(), last_done);
      last_done = data["frames_done"];
    }
    last_rank = rank;
    last = data;
  }
  EXPECT_EQ(last["state"], "succeeded");
  EXPECT_EQ(last["frames_done"], 30);
  EXPECT_EQ(last["frames_total"], 30);
  EXPECT_GE(events_seen, 2);
}

TEST_F(ServiceLive, ThumbnailsOfFramesAndPlotsOfAnAnalysis) {
  auto posted =
      daemon_.post(camera_ + "/captures",
                   {{"kind", "bracket"}, {"exposures_us", {1000, 2000, 4000}}, {"repeats", 2}});
  ASSERT_EQ(posted.status, 202);
  const int64_t capture = posted.json()["id"];
  ASSERT_EQ(daemon_.wait_finished(capture)["state"], "succeeded");
  const std::string jobs = "/v1/jobs/" + std::to_string(capture);

  auto thumbnail = daemon_.get(jobs + "/frames/0/thumbnail?width=100");
  ASSERT_EQ(thumbnail.status, 200) << thumbnail.body;
  EXPECT_EQ(thumbnail.headers["content-type"], "image/jpeg");
  const cv::Mat small = decode(thumbnail.body);
  EXPECT_EQ(small.cols, 100);
  EXPECT_EQ(small.rows, 75);
  EXPECT_EQ(daemon_.get(jobs + "/frames/6/thumbnail").error_code(), "not_found");
  EXPECT_EQ(daemon_.get(jobs + "/frames/0/thumbnail?width=5000").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get(jobs + "/plots").json()["plots"].size(), 0u);  // a capture draws none

  auto analysis = daemon_.post("/v1/analyses", {{"kind", "exposure"}, {"job", capture}});
  ASSERT_EQ(analysis.status, 202) << analysis.body;
  const int64_t id = analysis.json()["id"];
  const json done = daemon_.wait_finished(id);
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  const std::string plots_path = "/v1/jobs/" + std::to_string(id) + "/plots";
  std::set<std::string> names;
  const json listed = daemon_.get(plots_path).json();
  for (const auto& p : listed["plots"]) names.insert(p["name"].get<std::string>());
  EXPECT_TRUE(names.count("linearity.png"));
  // The test camera has no noise: no photon transfer curve, so no plot of one (the report
  // says why).
  const json& transfer = done["result"]["report"]["photon_transfer"];
  EXPECT_EQ(names.count("photon_transfer.png") == 1, !transfer.contains("error"))
      << transfer.dump();
  for (const auto& name : names) {
    auto png = daemon_.get(plots_path + "/" + name);
    ASSERT_EQ(png.status, 200);
    EXPECT_EQ(png.headers["content-type"], "image/png");
    EXPECT_FALSE(decode(png.body).empty()) << name;
  }
  // Only the plots themselves: no other file of the data folder by any name.
  EXPECT_EQ(daemon_.get(plots_path + "/..%2F..%2Ftoken").status, 400);
  EXPECT_EQ(daemon_.get(plots_path + "/token").error_code(), "not_found");
  EXPECT_EQ(daemon_.get(plots_path + "/..").error_code(), "not_found");
}

// The viewer's numbers: a region's statistics and samples are the stored frame's raw DN
// (the PNG decoded here by OpenCV, the statistics by cv::meanStdDev), and regions that are
// not inside the frame are refused with its size.
TEST_F(ServiceLive, ARegionOfAStoredFrameIsItsRawDn) {
  auto posted = daemon_.post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 1}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t capture = posted.json()["id"];
  ASSERT_EQ(daemon_.wait_finished(capture)["state"], "succeeded");
  const std::string frame = "/v1/jobs/" + std::to_string(capture) + "/frames/0";
  const cv::Mat stored = download_frame(daemon_, capture, 0).image;
  ASSERT_EQ(stored.channels(), 1);  // the test camera is mono

  const cv::Rect roi(7, 11, 41, 29);
  auto region = daemon_.get(frame + "/region?x=7&y=11&width=41&height=29");
  ASSERT_EQ(region.status, 200) << region.body;
  const json r = region.json();
  EXPECT_EQ(r["frame_width"], stored.cols);
  EXPECT_EQ(r["frame_height"], stored.rows);
  ASSERT_EQ(r["channels"].size(), 1u);
  const json& y = r["channels"][0];
  cv::Scalar mean, sd;
  cv::meanStdDev(stored(roi), mean, sd);  // population sd: n rather than n - 1
  const double n = roi.area();
  EXPECT_EQ(y["channel"], "Y");
  EXPECT_EQ(y["samples"], roi.area());
  EXPECT_NEAR(y["mean_dn"].get<double>(), mean[0], 1e-9 * mean[0]);
  EXPECT_NEAR(y["sd_dn"].get<double>(), sd[0] * std::sqrt(n / (n - 1)), 1e-6);
  double lo = 0, hi = 0;
  cv::minMaxLoc(stored(roi), &lo, &hi);
  EXPECT_EQ(y["min_dn"].get<double>(), lo);
  EXPECT_EQ(y["max_dn"].get<double>(), hi);
  EXPECT_TRUE(r["samples"].empty());  // too many to list

  auto cell = daemon_
                  .get(frame + "/region?x=" + std::to_string(stored.cols / 2) +
                       "&y=" + std::to_string(stored.rows / 2) + "&width=2&height=2")
                  .json();
  ASSERT_EQ(cell["samples"].size(), 4u) << cell.dump();
  for (const json& s : cell["samples"])
    EXPECT_EQ(s["dn"].get<int>(), stored.at<uint16_t>(s["y"].get<int>(), s["x"].get<int>()))
        << s.dump();

  auto outside = daemon_.get(frame + "/region?x=" + std::to_string(stored.cols - 1) + "&width=2");
  EXPECT_EQ(outside.error_code(), "out_of_range");
  EXPECT_NE(outside.body.find(std::to_string(stored.cols) + " x " + std::to_string(stored.rows)),
            std::string::npos)
      << outside.body;
  EXPECT_EQ(daemon_.get(frame + "/region?x=1.5").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get(frame + "/region?width=0").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get(frame + "/region?x=-1").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get("/v1/jobs/" + std::to_string(capture) + "/frames/1/region").error_code(),
            "not_found");
}

TEST_F(ServiceLive, BadLiveRequestsAreRefusedWithTheAllowedRange) {
  auto zero = daemon_.get(camera_ + "/live?fps=0");
  EXPECT_EQ(zero.error_code(), "invalid_request");
  EXPECT_NE(zero.json()["error"]["message"].get<std::string>().find("[0.2, 30]"), std::string::npos)
      << zero.body;
  EXPECT_EQ(daemon_.get(camera_ + "/live?width=8").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get(camera_ + "/live?peaking=maybe").error_code(), "invalid_request");
  EXPECT_EQ(daemon_.get("/v1/cameras/nope/live").error_code(), "not_found");

  std::vector<std::unique_ptr<StreamClient>> viewers;
  for (int i = 0; i < 8; ++i) {
    viewers.push_back(std::make_unique<StreamClient>());
    ASSERT_TRUE(viewers.back()->open(daemon_.port(), camera_ + "/live?fps=1", daemon_.token()));
    ASSERT_EQ(viewers.back()->status(), 200);
  }
  StreamClient ninth;
  ASSERT_TRUE(ninth.open(daemon_.port(), camera_ + "/live?fps=1", daemon_.token()));
  EXPECT_EQ(ninth.status(), 503);
  EXPECT_NE(ninth.error_body().find("too_many_connections"), std::string::npos);
  // A viewer that leaves frees its place.
  viewers.pop_back();
  bool reopened = false;
  for (int i = 0; i < 100 && !reopened; ++i) {
    StreamClient again;
    reopened = again.open(daemon_.port(), camera_ + "/live?fps=1", daemon_.token()) &&
               again.status() == 200;
    if (!reopened) std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(reopened);
}

TEST_F(ServiceLive, AViewerSeesTheCameraGoAndComeBack) {
  StreamClient live;
  ASSERT_TRUE(live.open(daemon_.port(), camera_ + "/live?fps=10", daemon_.token()));
  ASSERT_TRUE(live.next_part(10s));
  ASSERT_EQ(daemon_.post("/v1/test" + camera_.substr(3) + "/faults", {{"unplug", true}}).status,
            200);
  // The stream ends (the camera's feed closes when its worker is retired).
  bool ended = false;
  for (int i = 0; i < 200 && !ended; ++i) ended = !live.next_part(100ms) && live.ended();
  EXPECT_TRUE(ended) << "the live view kept its connection after the camera was unplugged";
  EXPECT_EQ(daemon_.get(camera_ + "/live").error_code(), "no_device");

  ASSERT_EQ(daemon_.post("/v1/test" + camera_.substr(3) + "/faults", {{"replug", true}}).status,
            200);
  bool back = false;
  for (int i = 0; i < 100 && !back; ++i) {
    StreamClient again;
    back = again.open(daemon_.port(), camera_ + "/live?fps=10", daemon_.token()) &&
           again.status() == 200 && again.next_part(5s).has_value();
    if (!back) std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(back) << "no live view once the camera was back";
}

// A Bayer camera's histogram counts each site of its mosaic under its own colour. The truth
// is the camera spec's quantum efficiency per channel: the scene is grey (the test's
// slanted edge), so the mean signals above black stand as 0.45 : 0.6 : 0.4 (R, G, B), and
// the two greens agree.
TEST(ServiceLiveColour, ABayerCamerasHistogramCountsEachSiteUnderItsColour) {
  const fs::path dir = fresh_test_dir("live_colour");
  write_test_specs(dir);
  Daemon daemon;
  ASSERT_TRUE(daemon.start(
      dir,
      {"--no-scan", "--camera-spec",
       (fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples/camera_colour_640x480.json").string(),
       "--scene", (dir / "scene.json").string()}))
      << daemon.log();
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  json h;
  for (int i = 0; i < 100 && !h.contains("channels"); ++i) {
    h = daemon.get(camera + "/histogram?bins=512").json();
    if (!h.contains("channels")) std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(h.contains("channels")) << h.dump();
  EXPECT_EQ(h["bit_depth"], 12);
  EXPECT_EQ(h["black_level_dn"], 64);
  EXPECT_EQ(h["bin_width_dn"], 8);
  std::map<std::string, json> by;
  for (const auto& c : h["channels"]) by[c["channel"]] = c;
  ASSERT_EQ(by.size(), 4u) << h.dump().substr(0, 400);
  for (const char* name : {"R", "Gr", "Gb", "B"}) {
    ASSERT_TRUE(by.count(name)) << name;
    EXPECT_EQ(by[name]["samples"], 640 * 480 / 4) << name;
    EXPECT_EQ(by[name]["clipped_high"], 0) << name;
  }
  const double black = 64;
  auto above = [&](const char* name) { return by[name]["mean_dn"].get<double>() - black; };
  const double green = 0.5 * (above("Gr") + above("Gb"));
  EXPECT_NEAR(above("Gr") / above("Gb"), 1.0, 0.01);
  EXPECT_NEAR(above("R") / green, 0.45 / 0.6, 0.03 * 0.75);
  EXPECT_NEAR(above("B") / green, 0.4 / 0.6, 0.03 * 0.667);
  EXPECT_EQ(daemon.stop(), 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace camlab::testing
