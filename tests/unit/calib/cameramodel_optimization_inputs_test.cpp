// A .cameramodel with mrcal's optimization_inputs (calib/model_io.h,
// cameramodel_text_with_inputs; calib/npz_writer.h), checked against mrcal itself: numpy
// reads the .npz writer's arrays with their dtypes and values, Python's base64 agrees with
// the base-85 encoder, mrcal's C reader loads the model, and mrcal 2.2's Python tools
// (through /usr/bin/python3: Debian's python3-mrcal) find the same solve camlab made: the
// same inlier RMS from mrcal.optimizer_callback, an optimum mrcal.optimize does not leave,
// the same projection uncertainty as calib/uncertainty.h, and a plot from
// mrcal-show-projection-uncertainty. Tests that need Python skip when it lacks numpy/mrcal.
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

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calib/model_io.h"
#include "calib/mrcal_api.h"
#include "calib/npz_writer.h"
#include "calib/solver.h"
#include "calib/uncertainty.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSigmaPx = 0.2;
constexpr const char* kPython = "/usr/bin/python3";

bool python_has(const char* module) {
  const std::string cmd = std::string(kPython) + " -c 'import " + module + "' > /dev/null 2>&1";
  return std::system(cmd.c_str()) == 0;
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("camlab_optin_" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// Runs the Python helper next to this file on `spec` and returns its JSON answer.
nlohmann::json mrcal_view(const TempDir& dir, const nlohmann::json& spec) {
  const std::string in = dir / "spec.json", out = dir / "answer.json";
  std::ofstream(in) << spec.dump();
  const std::string cmd = std::string(kPython) + " " + CAMLAB_SOURCE_DIR +
                          "/tests/unit/calib/mrcal_cameramodel_inputs.py " + in + " " + out;
  const auto t0 = std::chrono::steady_clock::now();
  const int rc = std::system(cmd.c_str());
  std::printf("  mrcal_cameramodel_inputs.py: %.2f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  if (rc != 0) return {{"failed", cmd}};
  nlohmann::json answer;
  std::ifstream(out) >> answer;
  return answer;
}

// 40 views of a 14 x 10 board through the wide OPENCV8 truth, 0.5% of the corners gross
// outliers (so mrcal's rejection marks some), solved with camlab's defaults.
struct Solved {
  CalibrationData data;
  Solution solution;
  std::string text;
};

const Solved& solved() {
  static const Solved s = [] {
    Solved out;
    testing::ViewSetSpec spec;
    spec.views = 40;
    spec.noise_px = kSigmaPx;
    spec.outlier_share = 0.005;
    spec.seed = 1;
    out.data = testing::make_views(testing::wide_opencv8_truth(), BoardSpec{14, 10, 0.03}, spec);
    SolveOptions o;
    o.lensmodel = "LENSMODEL_OPENCV8";
    auto sol = solve(out.data, o);
    if (sol) out.solution = std::move(*sol);
    auto text = cameramodel_text_with_inputs(out.solution, out.data, "camlab test");
    if (text) out.text = std::move(*text);
    return out;
  }();
  return s;
}

TEST(NpzWriter, NumpyReadsEveryEntryWithItsDtypeAndValues) {
  if (!python_has("numpy")) GTEST_SKIP() << kPython << " has no numpy";
  TempDir dir;
  NpzWriter npz;
  npz.add_float64("f", {0.1, -2.5e-300, 1e300, 3, 4, 5}, {2, 3});
  npz.add_float64("empty", {}, {0, 6});
  npz.add_float64("scalar", 0.030000000000000002);
  npz.add_int32("i", {0, 0, -1, 1, 0, -1}, {2, 3});
  npz.add_bool("t", true);
  npz.add_bool("f0", false);
  npz.add_string("none", "");
  npz.add_string("s", "LENSMODEL_OPENCV8");
  npz.add_strings("paths", {"a.png", "b\xc3\xa9.png", "bad\xff"});
  std::vector<double> big(5000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = std::sin(0.001 * i);
  npz.add_float64("big", big, {1000, 5});
  std::ofstream(dir / "a.npz", std::ios::binary) << npz.archive();
  // numpy's own reading of each entry: type, shape and values as repr (exact for doubles).
  const std::string script =
      "import numpy as np, json, sys\n"
      "d = np.load(sys.argv[1], allow_pickle=False)\n"
      "out = {k: [str(d[k].dtype), list(d[k].shape), repr(d[k].tolist())] for k in d.files}\n"
      "out['big_sum'] = float(d['big'].sum())\n"
      "json.dump(out, open(sys.argv[2], 'w'))\n";
  std::ofstream(dir / "read.py") << script;
  const std::string cmd = std::string(kPython) + " " + (dir / "read.py") + " " + (dir / "a.npz") +
                          " " + (dir / "out.json");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  nlohmann::json r;
  std::ifstream(dir / "out.json") >> r;
  using J = nlohmann::json;
  EXPECT_EQ(r["f"], J({"float64", {2, 3}, "[[0.1, -2.5e-300, 1e+300], [3.0, 4.0, 5.0]]"}));
  EXPECT_EQ(r["empty"], J({"float64", {0, 6}, "[]"}));
  EXPECT_EQ(r["scalar"], J({"float64", J::array(), "0.030000000000000002"}));
  EXPECT_EQ(r["i"], J({"int32", {2, 3}, "[[0, 0, -1], [1, 0, -1]]"}));
  EXPECT_EQ(r["t"], J({"bool", J::array(), "True"}));
  EXPECT_EQ(r["f0"], J({"bool", J::array(), "False"}));
  EXPECT_EQ(r["none"], J({"<U1", J::array(), "''"}));  // np.save('') exactly
  EXPECT_EQ(r["s"], J({"<U17", J::array(), "'LENSMODEL_OPENCV8'"}));
  EXPECT_EQ(r["paths"], J({"<U6", {3}, "['a.png', 'b\xc3\xa9.png', 'bad\xef\xbf\xbd']"}));
  double sum = 0;
  for (double v : big) sum += v;
  EXPECT_EQ(r["big"][1], J({1000, 5}));
  EXPECT_NEAR(r["big_sum"].get<double>(), sum, 1e-9 * std::fabs(sum));
}

TEST(NpzWriter, Base85MatchesPython) {
  // Python's base64.b85encode of these byte strings (every padding length, bytes >= 0x80).
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", ""},
      {std::string("\0", 1), "00"},
      {"a", "VE"},
      {"ab", "VPX"},
      {"abc", "VPaz"},
      {"abcd", "VPa!s"},
      {"abcde", "VPa!sWd"},
      {"\xff\xff\xff\xff\xfe", "|NsC0{r"},
      {"PK\x03\x04", "P)h>@"},
  };
  for (const auto& [in, out] : cases) EXPECT_EQ(base85_encode(in), out) << in;
}

TEST(CameramodelOptimizationInputs, MrcalCReaderLoadsTheModel) {
  const Solved& s = solved();
  ASSERT_FALSE(s.text.empty()) << "the solve or the export failed";
  EXPECT_NE(s.text.find("'optimization_inputs': b'"), std::string::npos);
  EXPECT_NE(s.text.find("'icam_intrinsics': 0,"), std::string::npos);
  std::printf("  40 views x 14 x 10 corners: model %zu bytes, without inputs %zu bytes\n",
              s.text.size(), cameramodel_text(s.solution.model, "camlab test").size());
  mrcal_cameramodel_t* m =
      mrcal_read_cameramodel_string(s.text.c_str(), static_cast<int>(s.text.size()));
  ASSERT_NE(m, nullptr);
  char name[128];
  mrcal_lensmodel_name(name, sizeof name, &m->lensmodel);
  EXPECT_STREQ(name, "LENSMODEL_OPENCV8");
  EXPECT_EQ(m->imagersize[0], 1280u);
  EXPECT_EQ(m->imagersize[1], 800u);
  for (size_t i = 0; i < s.solution.model.intrinsics.size(); ++i)
    EXPECT_EQ(m->intrinsics[i], s.solution.model.intrinsics[i]) << i;  // %.17g: exact
  mrcal_free_cameramodel(&m);
  // The file path too (what tests/bench/calib_bench.cpp and users call).
  TempDir dir;
  std::ofstream(dir / "camera.cameramodel") << s.text;
  m = mrcal_read_cameramodel_file((dir / "camera.cameramodel").c_str());
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->intrinsics[0], s.solution.model.intrinsics[0]);
  mrcal_free_cameramodel(&m);
}

TEST(CameramodelOptimizationInputs, MrcalPythonEvaluatesTheSameSolve) {
  if (!python_has("mrcal"))
    GTEST_SKIP() << kPython << " has no mrcal module (Debian's python3-mrcal)";
  const Solved& s = solved();
  ASSERT_FALSE(s.text.empty());
  ASSERT_TRUE(s.solution.covariance) << s.solution.covariance_error;
  ASSERT_GT(s.solution.outliers, 0) << "the scenario should make mrcal reject some corners";
  ASSERT_TRUE(std::none_of(s.solution.view_downweighted.begin(), s.solution.view_downweighted.end(),
                           [](char c) { return c; }))
      << "camlab leaves down-weighted views out of its mean of the boards, mrcal does not: "
         "the uncertainties compare only without them";
  TempDir dir;
  std::ofstream(dir / "camera.cameramodel") << s.text;
  const double w = s.solution.model.width_px - 1, h = s.solution.model.height_px - 1;
  struct Query {
    double x, y, d;
  };
  std::vector<Query> qs;
  for (double d : {kInf, 0.6})
    for (auto [fx, fy] : {std::pair{0.5, 0.5}, {0.1, 0.1}, {0.9, 0.15}, {0.25, 0.8}})
      qs.push_back({fx * w, fy * h, d});
  nlohmann::json spec = {{"model", dir / "camera.cameramodel"},
                         {"sigma_px", kSigmaPx},
                         {"downweighted_views", nlohmann::json::array()}};
  for (const auto& q : qs)
    spec["queries"].push_back(
        {{"x", q.x},
         {"y", q.y},
         {"distance_m", std::isfinite(q.d) ? nlohmann::json(q.d) : nlohmann::json()}});
  const nlohmann::json r = mrcal_view(dir, spec);
  ASSERT_FALSE(r.contains("failed")) << r["failed"];

  // Types as mrcal-calibrate-cameras stores them (0-d arrays come back as Python values).
  const auto& t = r["types"];
  const std::string nintr = std::to_string(s.solution.model.intrinsics.size());
  const std::string nviews = std::to_string(s.solution.views_used.size());
  EXPECT_EQ(t["lensmodel"], "str");
  EXPECT_EQ(t["intrinsics"], "float64 (1, " + nintr + ")");
  EXPECT_EQ(t["extrinsics_rt_fromref"], "float64 (0, 6)");
  EXPECT_EQ(t["frames_rt_toref"], "float64 (" + nviews + ", 6)");
  EXPECT_EQ(t["observations_board"], "float64 (" + nviews + ", 10, 14, 3)");
  EXPECT_EQ(t["indices_frame_camintrinsics_camextrinsics"], "int32 (" + nviews + ", 3)");
  EXPECT_EQ(t["imagersizes"], "int32 (1, 2)");
  EXPECT_EQ(t["calobject_warp"], "float64 (2,)");
  EXPECT_EQ(t["calibration_object_spacing"], "float");
  // The view names, "view0.png" .. "view39.png": as wide as the longest.
  EXPECT_EQ(t["imagepaths"], "<U10 (" + nviews + ",)");
  for (const char* key :
       {"points", "observations_point", "indices_point_camintrinsics_camextrinsics"})
    EXPECT_EQ(t[key], "NoneType") << key;
  for (const char* key :
       {"do_optimize_intrinsics_core", "do_optimize_intrinsics_distortions",
        "do_optimize_extrinsics", "do_optimize_frames", "do_optimize_calobject_warp",
        "do_apply_regularization", "do_apply_outlier_rejection", "verbose"})
    EXPECT_EQ(t[key], "bool") << key;
  EXPECT_EQ(r["icam_intrinsics"], 0);
  EXPECT_TRUE(r["intrinsics_equal"].get<bool>())
      << "the model's intrinsics must be the inputs' optimum";

  // mrcal's measurements of the stored problem give camlab's inlier RMS.
  std::printf("  inlier RMS: camlab %.9f px, mrcal %.9f px (%d inliers, %d outliers)\n",
              s.solution.rms_px, r["rms_px"].get<double>(), s.solution.inliers,
              s.solution.outliers);
  EXPECT_NEAR(r["rms_px"].get<double>() / s.solution.rms_px, 1.0, 1e-6);
  EXPECT_EQ(r["inliers"], s.solution.inliers);
  // It is the optimum of exactly this problem (weights, outliers, selections): restarting
  // mrcal's optimizer there moves no intrinsic by more than mrcal's convergence noise.
  std::printf("  mrcal.optimize from the stored state: largest relative change %.3g, RMS %.6f px\n",
              r["reoptimized_max_dintrinsics_rel"].get<double>(),
              r["reoptimized_rms_px"].get<double>());
  EXPECT_LT(r["reoptimized_max_dintrinsics_rel"].get<double>(), 1e-6);

  // mrcal's projection uncertainty off the file matches camlab's own.
  ASSERT_EQ(r["worst_px"].size(), qs.size());
  for (size_t i = 0; i < qs.size(); ++i) {
    auto ours = projection_uncertainty(s.solution, qs[i].x, qs[i].y, qs[i].d, kSigmaPx);
    ASSERT_TRUE(ours.ok()) << ours.error().message;
    const double theirs = r["worst_px"][i].get<double>();
    std::printf("  q (%6.1f, %6.1f) d %-4g worst stdev: camlab %.7f px, mrcal %.7f px\n", qs[i].x,
                qs[i].y, qs[i].d, ours->worst_px(), theirs);
    EXPECT_NEAR(ours->worst_px() / theirs, 1.0, 1e-4) << i;
  }
}

TEST(CameramodelOptimizationInputs, MrcalShowProjectionUncertaintyPlotsIt) {
  if (!python_has("mrcal"))
    GTEST_SKIP() << kPython << " has no mrcal module (Debian's python3-mrcal)";
  const Solved& s = solved();
  ASSERT_FALSE(s.text.empty());
  TempDir dir;
  std::ofstream(dir / "camera.cameramodel") << s.text;
  // gnuplot writes the PNG through its own terminal: no display needed.
  for (const std::string tool :
       {"mrcal-show-projection-uncertainty --cbmax 2", "mrcal-show-residuals --magnitudes"}) {
    const std::string png = dir / "plot.png";
    fs::remove(png);
    const std::string cmd = tool + " --hardcopy " + png + " " + (dir / "camera.cameramodel") +
                            " > " + (dir / "log.txt") + " 2>&1";
    const auto t0 = std::chrono::steady_clock::now();
    const int rc = std::system(cmd.c_str());
    std::printf("  %s: %.2f s\n", tool.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::ifstream log(dir / "log.txt");
    const std::string text((std::istreambuf_iterator<char>(log)), {});
    EXPECT_EQ(rc, 0) << cmd << "\n" << text;
    EXPECT_TRUE(fs::exists(png) && fs::file_size(png) > 1000) << cmd << "\n" << text;
  }
}

// A view whose corners are off by ~15 px (a mis-detected board) is kept at a weight of
// 1e-3 by the solver. Rebuilding the weights from the Solution alone (the path taken when
// the solve kept no covariance) must give the very pool the solver ended with, byte for
// byte, and mrcal must still find camlab's inlier RMS with that view left out.
TEST(CameramodelOptimizationInputs, WeightsRebuiltFromTheSolutionMatchTheSolversPool) {
  testing::ViewSetSpec spec;
  spec.views = 16;
  spec.noise_px = kSigmaPx;
  spec.outlier_share = 0.01;
  spec.seed = 9;
  CalibrationData data =
      testing::make_views(testing::wide_opencv8_truth(), BoardSpec{10, 7, 0.04}, spec);
  std::mt19937 rng(3);
  std::normal_distribution<double> far(0, 15);
  for (auto& c : data.views[4].corners) {
    c.x_px += far(rng);
    c.y_px += far(rng);
  }
  auto s = solve(data, SolveOptions{});
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->covariance) << s->covariance_error;
  std::vector<int> down;
  for (size_t i = 0; i < s->view_downweighted.size(); ++i)
    if (s->view_downweighted[i]) down.push_back(static_cast<int>(i));
  ASSERT_FALSE(down.empty()) << "the disturbed view should be down-weighted";
  int rejected = 0;  // outliers outside the down-weighted views: mrcal's own rejections
  for (const auto& r : s->residuals) {
    const size_t i =
        std::find(s->views_used.begin(), s->views_used.end(), r.view) - s->views_used.begin();
    rejected += r.outlier && !s->view_downweighted[i];
  }
  ASSERT_GT(rejected, 0);
  auto kept = cameramodel_text_with_inputs(*s, data, "kept");
  Solution bare = *s;
  bare.covariance.reset();
  auto rebuilt = cameramodel_text_with_inputs(bare, data, "kept");
  ASSERT_TRUE(kept.ok() && rebuilt.ok());
  EXPECT_TRUE(*kept == *rebuilt) << "the rebuilt inputs differ from the solver's final problem";

  if (!python_has("mrcal"))
    GTEST_SKIP() << kPython << " has no mrcal module (Debian's python3-mrcal)";
  TempDir dir;
  std::ofstream(dir / "camera.cameramodel") << *rebuilt;
  const nlohmann::json r = mrcal_view(dir, {{"model", dir / "camera.cameramodel"},
                                            {"sigma_px", kSigmaPx},
                                            {"downweighted_views", down},
                                            {"queries", nlohmann::json::array()}});
  ASSERT_FALSE(r.contains("failed")) << r["failed"];
  EXPECT_NEAR(r["rms_px"].get<double>() / s->rms_px, 1.0, 1e-6);
  EXPECT_EQ(r["inliers"], s->inliers);
  EXPECT_LT(r["reoptimized_max_dintrinsics_rel"].get<double>(), 1e-6);
}

TEST(CameramodelOptimizationInputs, DataOfAnotherSolveIsRefused) {
  const Solved& s = solved();
  CalibrationData other = s.data;
  other.views.resize(3);
  auto text = cameramodel_text_with_inputs(s.solution, other, "");
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().code, "invalid_argument");
}

}  // namespace
}  // namespace camlab::calib
