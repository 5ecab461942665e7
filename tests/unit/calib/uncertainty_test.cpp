// Projection uncertainty (calib/uncertainty.h) against the truth: the predicted spread of
// projections must match the spread over repeated solves with fresh noise (mrcal's own
// test-projection-uncertainty.py, "mean-frames"), and agree with mrcal's Python
// mrcal.projection_uncertainty on the same problem when /usr/bin/python3 has mrcal.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/solver.h"
#include "calib/uncertainty.h"
#include "mean_frames.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSigmaPx = 0.3;

struct Scenario {
  LensModel truth = testing::wide_opencv8_truth();
  BoardSpec board{10, 7, 0.05};
  std::vector<std::array<double, 6>> poses;
  CalibrationData clean;
};

const Scenario& scenario() {
  static const Scenario s = [] {
    Scenario sc;
    testing::ViewSetSpec spec;
    spec.views = 14;
    spec.noise_px = 0;
    spec.distance_min_m = 0.35;
    spec.distance_max_m = 0.7;
    spec.seed = 11;
    sc.clean = testing::make_views(sc.truth, sc.board, spec, &sc.poses);
    return sc;
  }();
  return s;
}

// The same views (same poses, same corners present) with fresh noise.
CalibrationData noisy(const Scenario& sc, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, kSigmaPx);
  CalibrationData d = sc.clean;
  for (auto& v : d.views)
    for (auto& c : v.corners) {
      c.x_px += n(rng);
      c.y_px += n(rng);
    }
  return d;
}

SolveOptions options() {
  SolveOptions o;
  o.lensmodel = "LENSMODEL_OPENCV8";
  o.reject_outliers = false;  // every solve uses the same corners
  return o;
}

struct Query {
  double x, y, d;
};

std::vector<Query> queries(const LensModel& m) {
  std::vector<Query> out;
  const double w = m.width_px - 1, h = m.height_px - 1;
  for (double d : {kInf, 0.5})
    for (auto [fx, fy] : {std::pair{0.5, 0.5}, {0.15, 0.15}, {0.85, 0.2}, {0.2, 0.85}, {0.8, 0.8}})
      out.push_back({fx * w, fy * h, d});
  return out;
}

TEST(ProjectionUncertainty, MatchesTheSpreadOfRepeatedNoisySolves) {
  const Scenario& sc = scenario();
  ASSERT_EQ(sc.clean.views.size(), 14u);
  auto base = solve(sc.clean, options());
  ASSERT_TRUE(base.ok()) << base.error().message;
  ASSERT_TRUE(base->covariance) << base->covariance_error;
  const auto qs = queries(sc.truth);
  constexpr int kSolves = 20;
  std::vector<std::vector<cv::Vec2d>> q(qs.size());
  for (int k = 0; k < kSolves; ++k) {
    auto s = solve(noisy(sc, 100 + k), options());
    ASSERT_TRUE(s.ok()) << s.error().message;
    ASSERT_EQ(s->rt_cam_board.size(), base->rt_cam_board.size());
    for (size_t i = 0; i < qs.size(); ++i)
      q[i].push_back(testing::reproject_mean_frames(*base, *s, qs[i].x, qs[i].y, qs[i].d));
  }
  double log_ratio_sum = 0;
  for (size_t i = 0; i < qs.size(); ++i) {
    cv::Vec2d mean(0, 0);
    for (const auto& v : q[i]) mean += v;
    mean *= 1.0 / kSolves;
    double sxx = 0, syy = 0;
    for (const auto& v : q[i]) {
      sxx += (v[0] - mean[0]) * (v[0] - mean[0]);
      syy += (v[1] - mean[1]) * (v[1] - mean[1]);
    }
    const double empirical_rms = std::sqrt((sxx + syy) / (2.0 * (kSolves - 1)));
    auto predicted = projection_uncertainty(*base, qs[i].x, qs[i].y, qs[i].d, kSigmaPx);
    ASSERT_TRUE(predicted.ok()) << predicted.error().message;
    const double ratio = empirical_rms / predicted->rms_px();
    std::printf(
        "  q (%6.1f, %6.1f) d %-4g predicted rms %.4f px (worst %.4f), empirical %.4f, ratio "
        "%.3f\n",
        qs[i].x, qs[i].y, qs[i].d, predicted->rms_px(), predicted->worst_px(), empirical_rms,
        ratio);
    // 20 solves estimate a stdev to about +-16% (1 sigma): 30% is two sigmas.
    EXPECT_GT(ratio, 0.7) << i;
    EXPECT_LT(ratio, 1.3) << i;
    log_ratio_sum += std::log(ratio);
  }
  // Over all ten queries the mean ratio is much better determined.
  EXPECT_NEAR(std::exp(log_ratio_sum / qs.size()), 1.0, 0.15);
}

TEST(ProjectionUncertainty, SigmaEstimatedFromTheResidualsMatchesTheNoise) {
  auto s = solve(noisy(scenario(), 7), options());
  ASSERT_TRUE(s.ok());
  ASSERT_TRUE(s->covariance);
  EXPECT_NEAR(s->covariance->observed_sigma_px, kSigmaPx, 0.1 * kSigmaPx);
  auto summary = summarize_uncertainty(*s);
  ASSERT_TRUE(summary.ok());
  ASSERT_EQ(summary->points.size(), 5u);
  EXPECT_NEAR(summary->working_distance_m, 0.52, 0.15);
  // Boards cover the centre: it is known better than the extrapolated corners.
  ASSERT_TRUE(summary->points[0].at_infinity_px);
  for (size_t i = 1; i < summary->points.size(); ++i) {
    if (summary->points[i].at_infinity_px) {
      EXPECT_GT(*summary->points[i].at_infinity_px, *summary->points[0].at_infinity_px);
    }
  }
  // The uncertainty scales with the noise: doubling sigma doubles it.
  auto a = projection_uncertainty(*s, 640, 400, kInf, 0.1);
  auto b = projection_uncertainty(*s, 640, 400, kInf, 0.2);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NEAR(b->worst_px() / a->worst_px(), 2.0, 1e-9);
}

TEST(ProjectionUncertainty, AgreesWithMrcalPython) {
  if (std::system("/usr/bin/python3 -c 'import mrcal' > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "/usr/bin/python3 has no mrcal module (Debian's python3-mrcal)";
  const CalibrationData data = noisy(scenario(), 7);
  auto s = solve(data, options());
  ASSERT_TRUE(s.ok());
  auto inputs = mrcal_optimization_inputs(data, *s);
  ASSERT_TRUE(inputs.ok()) << inputs.error().message;
  const auto qs = queries(s->model);
  nlohmann::json spec = {{"optimization_inputs", *inputs}, {"sigma_px", kSigmaPx}};
  for (const auto& q : qs)
    spec["queries"].push_back(
        {{"x", q.x},
         {"y", q.y},
         {"distance_m", std::isfinite(q.d) ? nlohmann::json(q.d) : nlohmann::json()}});
  const auto dir = std::filesystem::temp_directory_path();
  const auto in = dir / ("camlab_uncertainty_in_" + std::to_string(::getpid()) + ".json");
  const auto out = dir / ("camlab_uncertainty_out_" + std::to_string(::getpid()) + ".json");
  std::ofstream(in) << spec.dump();
  const std::string cmd = std::string("/usr/bin/python3 ") + CAMLAB_SOURCE_DIR +
                          "/tests/unit/calib/mrcal_uncertainty.py " + in.string() + " " +
                          out.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  nlohmann::json result;
  std::ifstream(out) >> result;
  std::filesystem::remove(in);
  std::filesystem::remove(out);
  ASSERT_EQ(result["worst_px"].size(), qs.size());
  for (size_t i = 0; i < qs.size(); ++i) {
    auto ours = projection_uncertainty(*s, qs[i].x, qs[i].y, qs[i].d, kSigmaPx);
    ASSERT_TRUE(ours.ok());
    const double theirs = result["worst_px"][i].get<double>();
    std::printf("  q (%6.1f, %6.1f) d %-4g camlab worst %.5f px, mrcal %.5f px\n", qs[i].x, qs[i].y,
                qs[i].d, ours->worst_px(), theirs);
    EXPECT_NEAR(ours->worst_px() / theirs, 1.0, 0.01) << i;
  }
}

}  // namespace
}  // namespace camlab::calib
