// Synchronised capture across a fleet on one machine: how far apart the cameras' frames
// start (docs/BENCHMARKS.md, "Fleet: synchronised capture"). A throwaway PostgreSQL
// cluster and three camlabd hosts with two virtual cameras each (the integration tests'
// fleet, tests/integration/service/fleet_harness.h); repeated synchronised captures of
// all six cameras, at two frame intervals. On one machine every host reads one clock, so
// the skew is what camlab adds: the hosts' waits for the start, the stream's start, the
// sensor's frame phase. A benchmark: it prints, never fails.
//
// Usage: fleet_sync_bench [--runs N] [--frames N]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tests/integration/service/fleet_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The test camera at `interval_us` per frame.
std::string camera_spec(int interval_us) {
  json camera = json::parse(kTestCameraSpec);
  camera["timing"]["frame_interval_us"] = interval_us;
  camera["controls"]["exposure_time_absolute"]["max"] = std::min(200, interval_us / 100);
  return camera.dump();
}

void run(int interval_us, int runs, int frames) {
  const fs::path dir = fresh_test_dir("fleet_sync_bench_" + std::to_string(interval_us));
  FleetHarness fleet(dir, camera_spec(interval_us));
  std::string error;
  if (!fleet.start_database(&error)) {
    std::printf("| %d | - | cluster: %s |\n", interval_us, error.c_str());
    return;
  }
  for (const char* name : {"host-1", "host-2", "host-3"})
    if (!fleet.start_host(name, 10000)) {
      std::printf("| %d | - | %s did not start |\n", interval_us, name);
      return;
    }
  const json ready = fleet.wait_live(*fleet.host("host-1"), 3);
  const std::vector<std::string> cameras = FleetHarness::camera_ids(ready);
  if (cameras.size() != 6) {
    std::printf("| %d | - | the fleet did not come up |\n", interval_us);
    return;
  }
  std::vector<double> worst_us, first_us, late_us, in_frames;
  for (int r = 0; r < runs; ++r) {
    const Daemon& via = *fleet.host(r % 2 ? "host-2" : "host-1");
    auto posted =
        via.post("/v1/sync-captures", {{"cameras", cameras},
                                       {"capture", {{"kind", "single"}, {"repeats", frames}}},
                                       {"start_in_ms", 1000}});
    if (posted.status != 202) {
      std::fprintf(stderr, "run %d: %d %s\n", r, posted.status, posted.body.c_str());
      continue;
    }
    const json job =
        via.wait_finished(posted.json()["id"].get<int64_t>(), std::chrono::seconds(60));
    if (job.value("state", "") != "succeeded") {
      std::fprintf(stderr, "run %d: %s\n", r, job.value("error", json::object()).dump().c_str());
      continue;
    }
    const json& result = job["result"];
    worst_us.push_back(result["skew_us"]["max"].get<double>());
    first_us.push_back(result["skew_us"]["first_view"].get<double>());
    in_frames.push_back(result["skew_frames"].get<double>());
    for (const json& camera : result["cameras"]) late_us.push_back(camera["late_us"].get<double>());
  }
  std::printf("| %d | %zu of %d | %.0f | %.0f | %.0f | %.2f | %.2f | %.0f |\n", interval_us,
              worst_us.size(), runs, median(first_us), median(worst_us),
              worst_us.empty() ? 0.0 : *std::max_element(worst_us.begin(), worst_us.end()),
              median(in_frames),
              in_frames.empty() ? 0.0 : *std::max_element(in_frames.begin(), in_frames.end()),
              median(late_us));
  fs::remove_all(dir);
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 10, frames = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--runs") runs = std::atoi(argv[i + 1]);
    if (flag == "--frames") frames = std::atoi(argv[i + 1]);
  }
  if (std::string missing = PgCluster::missing(); !missing.empty()) {
    std::printf("fleet_sync_bench: not measured: %s\n", missing.c_str());
    return 0;
  }
  std::printf(
      "fleet_sync_bench: 6 cameras (3 hosts x 2, 160x120) start 1 s after the request, "
      "%d frames each, %d runs per row\n\n",
      frames, runs);
  std::printf(
      "| frame interval us | runs ok | first-frame skew us (median) | max skew us "
      "(median) | max skew us (worst run) | skew in frames (median) | (worst) | start met "
      "late by us (median) |\n|---|---|---|---|---|---|---|---|\n");
  for (int interval_us : {10000, 33333}) run(interval_us, runs, frames);
  return 0;
}
