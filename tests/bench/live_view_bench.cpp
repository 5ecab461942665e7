// The dashboard's live view beside captures (docs/BENCHMARKS.md, "Live view beside a
// capture"): does the viewer hold its frame-rate cap while 300-frame captures run on the
// same camera, and does each capture keep every frame it keeps without the viewer?
//
//   live_view_bench [--seconds S] [--frames N] [--runs R] [--caps 10,30]
//
// On camlabd with the 640x480 example camera (30 frames/s, noise on, slanted edges), for
// each cap:
//   1. one viewer (GET /v1/cameras/{id}/live?fps=CAP, 640 px wide) for S seconds, while
//      N-frame captures run back to back: the viewer's frames/s over the whole run, during
//      the captures, and per 1-s window during them (minimum, median);
//   2. as many N-frame captures again with no viewer, at once after, so both see the
//      same machine: each capture's frames kept, dropped by the camera and by camlabd
//      (taken again, so they cost time, not frames), and wall time, with and without.
// Then the viewer alone (the idle preview) for 10 s. --runs R repeats it all. The viewer
// and the daemon share the machine's cores. Prints; never passes or fails.
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>

#include "daemon_harness.h"
#include "stream_client.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using SysClock = std::chrono::system_clock;

double now_s() { return std::chrono::duration<double>(SysClock::now().time_since_epoch()).count(); }

// "2026-11-26T21:58:22.843Z" -> Unix seconds.
double iso_seconds(const std::string& iso) {
  std::tm tm{};
  int ms = 0;
  if (std::sscanf(iso.c_str(), "%d-%d-%dT%d:%d:%d.%dZ", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                  &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &ms) < 6)
    return 0;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<double>(timegm(&tm)) + ms / 1000.0;
}

struct Capture {
  std::string state;
  int kept = 0, dropped = 0, dropped_by_camlabd = 0, dropped_by_device = 0;
  double wall_s = 0, started = 0, finished = 0;
};

Capture capture(const Daemon& daemon, const std::string& camera, int frames) {
  Capture out;
  auto posted = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", frames}});
  if (posted.status != 202) {
    out.state = "refused: " + posted.body;
    return out;
  }
  const json job = daemon.wait_finished(posted.json()["id"], std::chrono::seconds(600));
  out.state = job.value("state", "?");
  out.started = job["started_at"].is_string() ? iso_seconds(job["started_at"]) : 0;
  out.finished = job["finished_at"].is_string() ? iso_seconds(job["finished_at"]) : 0;
  if (job["result"].is_object()) {
    out.kept = job["result"].value("frames_kept", 0);
    out.dropped = job["result"].value("frames_dropped", 0);
    out.dropped_by_camlabd = job["result"].value("frames_dropped_by_camlabd", 0);
    out.dropped_by_device = job["result"].value("frames_dropped_by_device", 0);
    out.wall_s = job["result"].value("wall_seconds", 0.0);
  }
  return out;
}

// Reads a live view until told to stop; keeps each new frame's arrival time.
class Viewer {
 public:
  Viewer(int port, const std::string& path, const std::string& token) {
    if (!client_.open(port, path, token) || client_.status() != 200) {
      std::fprintf(stderr, "live view refused: %d %s\n", client_.status(),
                   client_.error_body().c_str());
      return;
    }
    thread_ = std::thread([this] {
      while (!stop_) {
        auto part = client_.next_part(std::chrono::milliseconds(500));
        if (!part) {
          if (client_.ended()) break;
          continue;
        }
        if (part->headers["x-frame-repeated"] == "1") continue;
        std::lock_guard lock(mutex_);
        arrivals_.push_back(now_s());
      }
    });
  }
  ~Viewer() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  // Frames that arrived in [from, to).
  int frames_between(double from, double to) const {
    std::lock_guard lock(mutex_);
    return static_cast<int>(std::count_if(arrivals_.begin(), arrivals_.end(),
                                          [&](double t) { return t >= from && t < to; }));
  }

 private:
  StreamClient client_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<double> arrivals_;
  std::thread thread_;
};

void print_capture(const char* condition, const Capture& c) {
  std::printf("| %s | %s | %d | %d | %d | %.2f | %.1f |\n", condition, c.state.c_str(), c.kept,
              c.dropped_by_device, c.dropped_by_camlabd, c.wall_s,
              c.wall_s > 0 ? c.kept / c.wall_s : 0.0);
  std::fflush(stdout);
}

template <class Get>
double median_of(const std::vector<Capture>& captures, Get get) {
  std::vector<double> v;
  for (const Capture& c : captures) v.push_back(get(c));
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 60;
  int frames = 300, runs = 1;
  std::vector<double> caps = {10, 30};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--seconds" && i + 1 < argc) {
      seconds = std::clamp(std::atof(argv[++i]), 5.0, 600.0);
    } else if (arg == "--frames" && i + 1 < argc) {
      frames = std::clamp(std::atoi(argv[++i]), 30, 3000);
    } else if (arg == "--runs" && i + 1 < argc) {
      runs = std::clamp(std::atoi(argv[++i]), 1, 20);
    } else if (arg == "--caps" && i + 1 < argc) {
      caps.clear();
      for (std::string list = argv[++i]; !list.empty();) {
        const size_t comma = list.find(',');
        caps.push_back(std::clamp(std::atof(list.substr(0, comma).c_str()), 0.2, 30.0));
        list = comma == std::string::npos ? "" : list.substr(comma + 1);
      }
    } else {
      std::fprintf(stderr,
                   "usage: live_view_bench [--seconds S] [--frames N] [--runs R] [--caps 10,30]\n");
      return 2;
    }
  }
  const fs::path dir = fresh_test_dir("live_view_bench");
  const std::string examples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
  Daemon daemon;
  if (!daemon.start(dir, {"--no-scan", "--camera-spec", examples + "/camera_640x480.json",
                          "--scene", examples + "/scene_slanted_edges.json"})) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return 1;
  }
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  capture(daemon, camera, 1);  // waits out the start-up latency probe

  std::printf("%d-frame single captures on the 640x480 example camera at 30 frames/s\n\n", frames);
  std::printf(
      "| condition | state | kept | dropped by camera | dropped by camlabd | wall s | kept/s |\n"
      "|---|---|---|---|---|---|---|\n");

  struct Row {
    double cap, overall, during, window_min, window_median;
    int windows;
    std::vector<Capture> beside, alone;
  };
  std::vector<Row> rows;
  for (int run = 0; run < runs; ++run)
    for (double cap : caps) {
      char label[64];
      std::snprintf(label, sizeof label, "viewer at %.0f/s", cap);
      char query[96];
      std::snprintf(query, sizeof query, "/live?fps=%g&width=640", cap);
      Row row{cap, 0, 0, 0, 0, 0, {}, {}};
      {
        Viewer viewer(daemon.port(), camera + query, daemon.token());
        const double start = now_s();
        while (now_s() - start < seconds) {
          row.beside.push_back(capture(daemon, camera, frames));
          print_capture(label, row.beside.back());
        }
        const double end = now_s();
        viewer.stop();
        row.overall = viewer.frames_between(start, end) / (end - start);
        double during_s = 0;
        int during_frames = 0;
        std::vector<int> windows;
        for (const Capture& c : row.beside) {
          if (c.finished <= c.started) continue;
          during_s += c.finished - c.started;
          during_frames += viewer.frames_between(c.started, c.finished);
          for (double t = c.started; t + 1 <= c.finished; t += 1)
            windows.push_back(viewer.frames_between(t, t + 1));
        }
        row.during = during_s > 0 ? during_frames / during_s : 0;
        std::sort(windows.begin(), windows.end());
        row.windows = static_cast<int>(windows.size());
        row.window_min = windows.empty() ? 0 : windows.front();
        row.window_median = windows.empty() ? 0 : windows[windows.size() / 2];
      }
      for (size_t i = 0; i < row.beside.size(); ++i) {
        row.alone.push_back(capture(daemon, camera, frames));
        print_capture("alone", row.alone.back());
      }
      rows.push_back(std::move(row));
    }

  Viewer idle(daemon.port(), camera + "/live?fps=10&width=640", daemon.token());
  const double idle_start = now_s();
  std::this_thread::sleep_for(std::chrono::seconds(10));
  const double idle_rate =
      idle.frames_between(idle_start + 2, now_s()) / (now_s() - idle_start - 2);
  idle.stop();

  std::printf(
      "\nThe viewer (640 px wide JPEG), %.0f s per cap while captures run back to back\n\n"
      "| cap /s | viewer frames/s overall | during captures | 1-s windows during captures: "
      "min | median | windows |\n|---|---|---|---|---|---|\n",
      seconds);
  for (const Row& r : rows)
    std::printf("| %.0f | %.2f | %.2f | %.0f | %.0f | %d |\n", r.cap, r.overall, r.during,
                r.window_min, r.window_median, r.windows);
  std::printf(
      "\nThe captures beside the viewer and alone right after (medians)\n\n"
      "| cap /s | captures | kept with / without | dropped by camlabd with / without | "
      "dropped by camera with / without | wall s with / without |\n|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %.0f | %zu + %zu | %.0f / %.0f | %.0f / %.0f | %.0f / %.0f | %.2f / %.2f |\n",
                r.cap, r.beside.size(), r.alone.size(),
                median_of(r.beside, [](const Capture& c) { return c.kept; }),
                median_of(r.alone, [](const Capture& c) { return c.kept; }),
                median_of(r.beside, [](const Capture& c) { return c.dropped_by_camlabd; }),
                median_of(r.alone, [](const Capture& c) { return c.dropped_by_camlabd; }),
                median_of(r.beside, [](const Capture& c) { return c.dropped_by_device; }),
                median_of(r.alone, [](const Capture& c) { return c.dropped_by_device; }),
                median_of(r.beside, [](const Capture& c) { return c.wall_s; }),
                median_of(r.alone, [](const Capture& c) { return c.wall_s; }));
  std::printf("\nThe viewer alone (idle preview, cap 10/s): %.2f frames/s\n", idle_rate);
  daemon.stop();
  fs::remove_all(dir);
  return 0;
}
