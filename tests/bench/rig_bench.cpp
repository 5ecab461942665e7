// Rig calibration speed against error (docs/measuring.md): the joint solve of
// calib/rig/rig_solver.h on synthetic rigs (tests/unit/calib/synthetic_rig.h) over many
// noise seeds. Prints, for a 640x480 + 1280x800 pair (30 views, 0.3 px noise): each
// extrinsic component's error over its stated sigma (RMS and share beyond 2 sigma), the
// worst errors, a triangulated range's error over its sigma; and for a ring of 4 wide
// cameras, 50 rig views: the solve time and each camera's error; and the ring with a 180 deg
// fisheye, each camera in its own model, over the seeds: error over sigma and solve time.
//
//   rig_bench [--seeds N] [--ring-views N]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "calib/rig/rig_pose.h"
#include "calib/rig/rig_range.h"
#include "calib/rig/rig_solver.h"
#include "synthetic_rig.h"

using namespace camlab::calib;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

void pair_statistics(int seeds) {
  const auto truth = testing::stereo_pair_truth();
  std::vector<double> z, range_z, times;
  double worst_deg = 0, worst_mm = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::RigViewSpec spec;
    spec.seed = seed;
    const RigData data = testing::make_rig_views(truth, BoardSpec{10, 7, 0.05}, spec);
    RigSolveOptions options;
    options.lensmodel = "LENSMODEL_OPENCV4";
    auto s = solve_rig(data, options);
    if (!s) {
      std::printf("seed %d: %s\n", seed, s.error().text().c_str());
      continue;
    }
    times.push_back(s->solve_s);
    const RigCamera& b = s->cameras[1];
    for (int k = 0; k < 6; ++k)
      z.push_back((b.rt_cam_ref[k] - truth[1].rt_cam_ref[k]) / std::sqrt(b.rt_covariance[7 * k]));
    worst_deg = std::max(worst_deg, rotation_between_deg(b.rt_cam_ref, truth[1].rt_cam_ref));
    worst_mm = std::max(worst_mm, 1000 * std::hypot(b.rt_cam_ref[3] - truth[1].rt_cam_ref[3],
                                                    b.rt_cam_ref[4] - truth[1].rt_cam_ref[4],
                                                    b.rt_cam_ref[5] - truth[1].rt_cam_ref[5]));
    auto range = triangulated_range_uncertainty(*s, 1, 3.0);
    const auto range_error_mm = testing::range_error_mm(*s, truth, 1, 3.0);
    if (range && range_error_mm) range_z.push_back(*range_error_mm / range->sigma_mm);
  }
  auto rms = [](const std::vector<double>& v) {
    double sum = 0;
    for (double x : v) sum += x * x;
    return std::sqrt(sum / std::max<size_t>(1, v.size()));
  };
  const auto beyond = std::count_if(z.begin(), z.end(), [](double x) { return std::abs(x) > 2; });
  std::printf(
      "pair 640x480 + 1280x800, 30 views, 0.3 px, %d seeds: extrinsics |error|/sigma "
      "RMS %.3f, %ld of %zu components beyond 2 sigma (%.1f%%); worst %.4f deg, "
      "%.3f mm; range at 3 m |error|/sigma RMS %.3f; solve median %.3f s\n",
      seeds, rms(z), static_cast<long>(beyond), z.size(), 100.0 * beyond / z.size(), worst_deg,
      worst_mm, rms(range_z), median(times));
}

void ring_timing(int views, int seeds) {
  // 55 deg apart, not 60: camera 3 at 180 deg would have a rotation vector at the branch
  // cut (r and -r the same rotation), where components cannot be compared.
  const auto truth = testing::ring_truth(55);
  std::vector<double> times;
  double worst_z = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::RigViewSpec spec;
    spec.views = views;
    spec.seed = seed;
    spec.distance_min_m = 0.6;
    spec.distance_max_m = 1.4;
    const RigData data = testing::make_rig_views(truth, BoardSpec{10, 7, 0.05}, spec);
    auto s = solve_rig(data, RigSolveOptions{});
    if (!s) {
      std::printf("ring seed %d: %s\n", seed, s.error().text().c_str());
      continue;
    }
    times.push_back(s->solve_s);
    for (int c = 1; c < 4; ++c)
      for (int k = 0; k < 6; ++k)
        worst_z = std::max(worst_z, std::abs(s->cameras[c].rt_cam_ref[k] - truth[c].rt_cam_ref[k]) /
                                        std::sqrt(s->cameras[c].rt_covariance[7 * k]));
  }
  std::printf(
      "ring of 4 OPENCV8 cameras 55 deg apart, %d rig views, %d seeds: solve median %.2f s, max "
      "%.2f s; worst component |error|/sigma %.2f\n",
      views, seeds, median(times),
      times.empty() ? 0 : *std::max_element(times.begin(), times.end()), worst_z);
}

// The ring with a 180 deg fisheye (camera 1, stereographic), 60 deg apart, 50 rig
// views, each camera in its own model (the stacked per-camera solve): every extrinsic
// component's error over its sigma, in the solution's chart of the rotation.
void fisheye_ring_statistics(int seeds) {
  const auto truth = testing::ring_with_fisheye_truth(60, 1);
  std::vector<double> z, times;
  double worst_deg = 0, worst_mm_per_m = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::RigViewSpec spec;
    spec.views = 50;
    spec.seed = seed;
    spec.distance_min_m = 0.6;
    spec.distance_max_m = 1.4;
    const RigData data = testing::make_rig_views(truth, BoardSpec{10, 7, 0.05}, spec);
    RigSolveOptions options;
    for (const auto& cam : truth) options.lensmodels.push_back(cam.lens.lensmodel);
    auto s = solve_rig(data, options);
    if (!s) {
      std::printf("fisheye ring seed %d: %s\n", seed, s.error().text().c_str());
      continue;
    }
    times.push_back(s->solve_s);
    for (int c = 1; c < 4; ++c) {
      const RigCamera& cam = s->cameras[c];
      const Rt exact = testing::rt_nearest(truth[c].rt_cam_ref, cam.rt_cam_ref);
      for (int k = 0; k < 6; ++k)
        z.push_back((cam.rt_cam_ref[k] - exact[k]) / std::sqrt(cam.rt_covariance[7 * k]));
      worst_deg = std::max(worst_deg, rotation_between_deg(cam.rt_cam_ref, exact));
      worst_mm_per_m = std::max(
          worst_mm_per_m, 1000 *
                              std::hypot(cam.rt_cam_ref[3] - exact[3], cam.rt_cam_ref[4] - exact[4],
                                         cam.rt_cam_ref[5] - exact[5]) /
                              cam.baseline_m);
    }
  }
  double sum = 0;
  for (double x : z) sum += x * x;
  const auto beyond = std::count_if(z.begin(), z.end(), [](double x) { return std::abs(x) > 2; });
  std::printf(
      "ring of 4 (OPENCV8 x 3 + STEREOGRAPHIC 180 deg) 60 deg apart, 50 rig views, a model "
      "per camera, %d seeds: extrinsics |error|/sigma RMS %.3f, %ld of %zu beyond 2 sigma "
      "(%.1f%%); worst rotation %.4f deg, worst translation %.3f mm per m of baseline; solve "
      "median %.2f s, max %.2f s\n",
      seeds, std::sqrt(sum / std::max<size_t>(1, z.size())), static_cast<long>(beyond), z.size(),
      100.0 * beyond / std::max<size_t>(1, z.size()), worst_deg, worst_mm_per_m, median(times),
      times.empty() ? 0 : *std::max_element(times.begin(), times.end()));
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 50, ring_views = 50;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--seeds")) seeds = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--ring-views")) ring_views = std::atoi(argv[i + 1]);
  }
  pair_statistics(seeds);
  ring_timing(ring_views, 5);
  fisheye_ring_statistics(seeds);
  return 0;
}
