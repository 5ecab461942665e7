// calib_bench_uncertainty: the projection uncertainty (calib/uncertainty.h) against the
// truth and against mrcal, with what it costs.
//  1. Cost: solve time with and without the covariance (median of --repeats).
//  2. Predicted vs empirical: the worst-direction/RMS stdev predicted from one solve
//     against the spread of projections over --solves re-solves with fresh noise (mrcal's
//     mean-frames reprojection, as its test-projection-uncertainty.py).
//  3. mrcal: the same problem through /usr/bin/python3's mrcal.projection_uncertainty
//     (tests/unit/calib/mrcal_uncertainty.py), when available.
//
//   calib_bench_uncertainty [--views N] [--noise PX] [--solves N] [--repeats N]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/solver.h"
#include "calib/uncertainty.h"
#include "mean_frames.h"
#include "synthetic_views.h"

namespace {

using namespace camlab::calib;
constexpr double kInf = std::numeric_limits<double>::infinity();

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int views = 40, solves = 30, repeats = 3;
  double noise = 0.3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--views" && i + 1 < argc)
      views = std::atoi(argv[++i]);
    else if (a == "--noise" && i + 1 < argc)
      noise = std::atof(argv[++i]);
    else if (a == "--solves" && i + 1 < argc)
      solves = std::max(3, std::atoi(argv[++i]));
    else if (a == "--repeats" && i + 1 < argc)
      repeats = std::max(1, std::atoi(argv[++i]));
    else {
      std::fprintf(
          stderr,
          "usage: calib_bench_uncertainty [--views N] [--noise PX] [--solves N] [--repeats N]\n");
      return 2;
    }
  }
  const LensModel truth = testing::wide_opencv8_truth();
  const BoardSpec board{14, 10, 0.04};
  testing::ViewSetSpec spec;
  spec.views = views;
  spec.noise_px = 0;
  const CalibrationData clean = testing::make_views(truth, board, spec);
  auto noisy = [&](uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, noise);
    CalibrationData d = clean;
    for (auto& v : d.views)
      for (auto& c : v.corners) {
        c.x_px += n(rng);
        c.y_px += n(rng);
      }
    return d;
  };
  SolveOptions with, without;
  with.lensmodel = without.lensmodel = "LENSMODEL_OPENCV8";
  with.reject_outliers = without.reject_outliers = false;
  without.compute_covariance = false;

  std::printf(
      "## Projection uncertainty: %d views of a %dx%d board, OPENCV8 wide lens (1280x800), noise "
      "%.2f px\n\n",
      static_cast<int>(clean.views.size()), board.cols, board.rows, noise);
  std::vector<double> t_with, t_without;
  const CalibrationData sample = noisy(1);
  for (int k = 0; k < repeats; ++k) {
    double t0 = now_s();
    (void)solve(sample, without);
    t_without.push_back(now_s() - t0);
    t0 = now_s();
    (void)solve(sample, with);
    t_with.push_back(now_s() - t0);
  }
  std::printf(
      "| solve | median s |\n|---|---:|\n| without covariance | %.3f |\n| with covariance | %.3f "
      "|\n\n",
      median(t_without), median(t_with));

  auto base = solve(clean, with);
  if (!base || !base->covariance) {
    std::fprintf(stderr, "calib_bench_uncertainty: the noise-free solve failed\n");
    return 1;
  }
  struct Query {
    const char* where;
    double fx, fy, d;
  };
  std::vector<Query> qs;
  for (double d : {kInf, 0.6})
    for (auto [name, fx, fy] : {std::tuple{"centre", 0.5, 0.5},
                                {"(0.1, 0.1) of the imager", 0.1, 0.1},
                                {"(0.9, 0.9) of the imager", 0.9, 0.9},
                                {"top-left corner", 0.0, 0.0}})
      qs.push_back({name, fx, fy, d});
  std::vector<std::vector<cv::Vec2d>> q(qs.size());
  for (int k = 0; k < solves; ++k) {
    auto s = solve(noisy(100 + k), without);
    if (!s || s->rt_cam_board.size() != base->rt_cam_board.size()) continue;
    for (size_t i = 0; i < qs.size(); ++i)
      q[i].push_back(testing::reproject_mean_frames(*base, *s, qs[i].fx * (truth.width_px - 1),
                                                    qs[i].fy * (truth.height_px - 1), qs[i].d));
  }
  // mrcal on the same problem (one noisy solve), when /usr/bin/python3 has it.
  std::vector<double> mrcal_worst(qs.size(), std::nan(""));
  const bool have_mrcal = std::system("/usr/bin/python3 -c 'import mrcal' > /dev/null 2>&1") == 0;
  auto one = solve(sample, with);
  if (have_mrcal && one) {
    auto inputs = mrcal_optimization_inputs(sample, *one);
    nlohmann::json spec_json = {{"optimization_inputs", *inputs}, {"sigma_px", noise}};
    for (const auto& qq : qs)
      spec_json["queries"].push_back(
          {{"x", qq.fx * (truth.width_px - 1)},
           {"y", qq.fy * (truth.height_px - 1)},
           {"distance_m", std::isfinite(qq.d) ? nlohmann::json(qq.d) : nlohmann::json()}});
    const auto dir = std::filesystem::temp_directory_path();
    const auto in = dir / ("camlab_bench_unc_in_" + std::to_string(getpid()) + ".json");
    const auto out = dir / ("camlab_bench_unc_out_" + std::to_string(getpid()) + ".json");
    std::ofstream(in) << spec_json.dump();
    const std::string cmd = std::string("/usr/bin/python3 ") + CAMLAB_SOURCE_DIR +
                            "/tests/unit/calib/mrcal_uncertainty.py " + in.string() + " " +
                            out.string();
    if (std::system(cmd.c_str()) == 0) {
      nlohmann::json r;
      std::ifstream(out) >> r;
      for (size_t i = 0; i < qs.size(); ++i) mrcal_worst[i] = r["worst_px"][i].get<double>();
    }
    std::filesystem::remove(in);
    std::filesystem::remove(out);
  }
  std::printf(
      "Predicted (noise-free solve, sigma %.2f px) against the spread of %zu re-solves with fresh "
      "noise;\n"
      "camlab and mrcal.projection_uncertainty on one noisy solve (worst direction):\n\n",
      noise, q[0].size());
  std::printf(
      "| point | distance | predicted rms px | empirical rms px | empirical / predicted | camlab "
      "worst px | mrcal worst px | camlab / mrcal |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|\n");
  for (size_t i = 0; i < qs.size(); ++i) {
    const double x = qs[i].fx * (truth.width_px - 1), y = qs[i].fy * (truth.height_px - 1);
    auto p = projection_uncertainty(*base, x, y, qs[i].d, noise);
    cv::Vec2d mean(0, 0);
    for (const auto& v : q[i]) mean += v;
    mean *= 1.0 / q[i].size();
    double ss = 0;
    for (const auto& v : q[i])
      ss += (v[0] - mean[0]) * (v[0] - mean[0]) + (v[1] - mean[1]) * (v[1] - mean[1]);
    const double empirical = std::sqrt(ss / (2.0 * (q[i].size() - 1)));
    auto ours = one ? projection_uncertainty(*one, x, y, qs[i].d, noise) : p;
    std::printf("| %s | %s | %.4f | %.4f | %.2f | %.5f | %.5f | %.5f |\n", qs[i].where,
                std::isfinite(qs[i].d) ? "0.6 m" : "infinity", p ? p->rms_px() : NAN, empirical,
                p ? empirical / p->rms_px() : NAN, ours ? ours->worst_px() : NAN, mrcal_worst[i],
                ours ? ours->worst_px() / mrcal_worst[i] : NAN);
  }
  return 0;
}
