// Calibration speed against error (docs/measuring.md). On one set of corners (40 views of a
// 14x10 board, 40 mm squares, through the OPENCV8 wide lens of
// mock_device/examples/camera_wide_1280x800.json, Gaussian noise, fixed seed; or a
// corners.vnl given with --corners), prints per lens model: median solve time, RMS,
// projection error against the truth (rotation-fitted, central 80% of the imager) and
// FOV error; then OpenCV's calibrateCamera and mrcal-calibrate-cameras (when installed)
// on the same corners in the same run, with time ratios.
//
//   calib_bench [--views N] [--noise PX] [--repeats N] [--no-peers]
//               [--corners FILE.vnl --truth TRUTH.cameramodel [--board 14x10 --spacing-m 0.04]]
//
// With --corners, the corners (e.g. from `camlab calibrate --write-corners` on rendered
// frames) and the truth model (the frames' truth cameramodel) replace the synthetic set.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "calib/corners/corners_vnl.h"
#include "calib/lens_model.h"
#include "calib/model_selection.h"
#include "calib/mrcal_api.h"
#include "calib/solver.h"
#include "synthetic_views.h"

using namespace camlab::calib;
using camlab::make_error;
using camlab::Result;

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

struct Row {
  std::string method;
  int params = 0;
  double time_s = 0;
  double rms_px = -1;
  double diff_px = -1;
  double fov_err_deg = -1;
  std::string note;
};

void errors_vs_truth(const LensModel& truth, const LensModel& fit, Row* row) {
  if (auto d = projection_difference(truth, fit, 0.8); d.ok()) row->diff_px = d->rms_px;
  auto ft = field_of_view(truth);
  auto f = field_of_view(fit);
  if (ft.ok() && f.ok()) row->fov_err_deg = std::fabs(f->horizontal_deg - ft->horizontal_deg);
}

// Solves `repeats` times: the median solve time and the errors of the last solve, or why
// it failed.
void time_solve(const CalibrationData& data, const SolveOptions& options, int repeats,
                const LensModel& truth, Row* row) {
  std::vector<double> times;
  Result<Solution> s = make_error("internal", "not run yet");
  for (int r = 0; r < repeats; ++r) {
    s = solve(data, options);
    if (!s) break;
    times.push_back(s->solve_s);
  }
  if (!s) {
    row->note = "failed: " + s.error().message;
    return;
  }
  row->time_s = median(times);
  row->rms_px = s->rms_px;
  errors_vs_truth(truth, s->model, row);
}

Row opencv_calibrate(const CalibrationData& data, const LensModel& truth, int repeats) {
  Row row;
  row.method = "OpenCV calibrateCamera (rational, 8 coeffs)";
  row.params = 12;
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (const auto& v : data.views) {
    std::vector<cv::Point3f> o;
    std::vector<cv::Point2f> i;
    for (size_t k = 0; k < v.corners.size(); ++k) {
      if (!v.corners[k].present) continue;
      o.emplace_back((k % data.board.cols) * data.board.spacing_m,
                     (k / data.board.cols) * data.board.spacing_m, 0.f);
      i.emplace_back(v.corners[k].x_px, v.corners[k].y_px);
    }
    obj.push_back(o);
    img.push_back(i);
  }
  std::vector<double> times;
  cv::Mat K, D;
  double rms = 0;
  for (int r = 0; r < repeats; ++r) {
    std::vector<cv::Mat> rv, tv;
    const double t0 = now_s();
    try {
      rms = cv::calibrateCamera(obj, img, cv::Size(data.imager_width_px, data.imager_height_px), K,
                                D, rv, tv, cv::CALIB_RATIONAL_MODEL);
    } catch (const cv::Exception& e) {
      row.note = "failed: " + std::string(e.what()).substr(0, 60);
      return row;
    }
    times.push_back(now_s() - t0);
  }
  row.time_s = median(times);
  row.rms_px = rms;  // OpenCV's RMS is per coordinate pair, as ours
  LensModel fit{"LENSMODEL_OPENCV8",
                {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)},
                data.imager_width_px,
                data.imager_height_px};
  for (int k = 0; k < 8; ++k) fit.intrinsics.push_back(D.at<double>(k));
  errors_vs_truth(truth, fit, &row);
  return row;
}

Row mrcal_tool(const CalibrationData& data, const LensModel& truth) {
  Row row;
  row.method = "mrcal-calibrate-cameras OPENCV8 (--focal 700)";
  row.params = 12;
  if (std::system("command -v mrcal-calibrate-cameras >/dev/null 2>&1") != 0) {
    row.note = "not installed";
    return row;
  }
  const auto dir =
      std::filesystem::temp_directory_path() / ("calib_bench_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "corners.vnl") << to_corners_vnl(data.views);
  const std::string cmd =
      "cd " + dir.string() +
      " && mrcal-calibrate-cameras --corners-cache corners.vnl --lensmodel LENSMODEL_OPENCV8"
      " --focal 700 --object-spacing " +
      std::to_string(data.board.spacing_m) + " --object-width-n " +
      std::to_string(data.board.cols) + " --object-height-n " + std::to_string(data.board.rows) +
      " --imagersize " + std::to_string(data.imager_width_px) + " " +
      std::to_string(data.imager_height_px) + " --outdir . '*' > log.txt 2>&1";
  const double t0 = now_s();
  const int rc = std::system(cmd.c_str());
  row.time_s = now_s() - t0;
  mrcal_cameramodel_t* m =
      rc == 0 ? mrcal_read_cameramodel_file((dir / "camera-0.cameramodel").c_str()) : nullptr;
  if (!m) {
    row.note = "failed (see its log)";
  } else {
    char name[128];
    mrcal_lensmodel_name(name, sizeof name, &m->lensmodel);
    LensModel fit{name,
                  std::vector<double>(m->intrinsics,
                                      m->intrinsics + mrcal_lensmodel_num_params(&m->lensmodel)),
                  data.imager_width_px, data.imager_height_px};
    mrcal_free_cameramodel(&m);
    errors_vs_truth(truth, fit, &row);
    row.note = "wall time incl. Python start-up; 6-decimal output";
  }
  std::filesystem::remove_all(dir);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  int views = 40, repeats = 3;
  double noise = 0.1;
  bool peers = true;
  std::string corners_path, truth_path, write_corners_path;
  BoardSpec board{14, 10, 0.04};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--views" && i + 1 < argc)
      views = std::atoi(argv[++i]);
    else if (a == "--noise" && i + 1 < argc)
      noise = std::atof(argv[++i]);
    else if (a == "--repeats" && i + 1 < argc)
      repeats = std::max(1, std::atoi(argv[++i]));
    else if (a == "--no-peers")
      peers = false;
    else if (a == "--corners" && i + 1 < argc)
      corners_path = argv[++i];
    else if (a == "--truth" && i + 1 < argc)
      truth_path = argv[++i];
    else if (a == "--board" && i + 1 < argc)
      std::sscanf(argv[++i], "%dx%d", &board.cols, &board.rows);
    else if (a == "--spacing-m" && i + 1 < argc)
      board.spacing_m = std::atof(argv[++i]);
    else if (a == "--write-corners" && i + 1 < argc)
      write_corners_path = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: calib_bench [--views N] [--noise PX] [--repeats N] [--no-peers] "
                   "[--corners FILE.vnl --truth TRUTH.cameramodel [--board CxR --spacing-m S]] "
                   "[--write-corners OUT.vnl]\n");
      return 2;
    }
  }
  LensModel truth = testing::wide_opencv8_truth();
  CalibrationData data;
  std::string source;
  if (!corners_path.empty()) {
    mrcal_cameramodel_t* m = mrcal_read_cameramodel_file(truth_path.c_str());
    auto read = read_corners_vnl(corners_path, board);
    if (!m || !read) {
      std::fprintf(stderr, "calib_bench: cannot read --corners and --truth\n");
      return 2;
    }
    char name[128];
    mrcal_lensmodel_name(name, sizeof name, &m->lensmodel);
    truth = {name,
             std::vector<double>(m->intrinsics,
                                 m->intrinsics + mrcal_lensmodel_num_params(&m->lensmodel)),
             static_cast<int>(m->imagersize[0]), static_cast<int>(m->imagersize[1])};
    mrcal_free_cameramodel(&m);
    data.board = board;
    data.imager_width_px = truth.width_px;
    data.imager_height_px = truth.height_px;
    data.views = std::move(*read);
    source = corners_path + ", truth " + truth_path;
  } else {
    testing::ViewSetSpec spec;
    spec.views = views;
    spec.noise_px = noise;
    data = testing::make_views(truth, board, spec);
    source = "synthetic, OPENCV8 wide truth, noise " + std::to_string(noise).substr(0, 4) + " px";
  }
  if (!write_corners_path.empty()) {
    // The same corners for `camlab calibrate --corners` and mrcal's tools.
    std::ofstream(write_corners_path) << to_corners_vnl(data.views);
    std::printf("wrote %s\n", write_corners_path.c_str());
  }
  int corners = 0;
  for (const auto& v : data.views) corners += v.present_count();
  std::printf(
      "calib_bench: %zu views of a %dx%d board (%d corners present), %dx%d, %s, median of %d "
      "runs\n\n",
      data.views.size(), board.cols, board.rows, corners, data.imager_width_px,
      data.imager_height_px, source.c_str(), repeats);

  std::vector<Row> rows;
  for (const std::string name : {"LENSMODEL_PINHOLE", "LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5",
                                 "LENSMODEL_OPENCV8", "LENSMODEL_OPENCV12"}) {
    Row row;
    row.method = "camlab " + name;
    row.params = *lensmodel_param_count(name);
    SolveOptions o;
    o.lensmodel = name;
    time_solve(data, o, repeats, truth, &row);
    rows.push_back(row);
  }
  {
    // Knob: the board-warp stage (a flat board needs none; it costs a stage).
    Row row;
    row.method = "camlab LENSMODEL_OPENCV8, no board warp";
    row.params = 12;
    SolveOptions o;
    o.lensmodel = "LENSMODEL_OPENCV8";
    o.board_warp = false;
    time_solve(data, o, repeats, truth, &row);
    rows.push_back(row);
  }
  {
    Row row;
    row.method = "camlab --model auto (3-fold CV)";
    const double t0 = now_s();
    auto sel = select_model(data, SolveOptions{}, default_candidate_models());
    row.time_s = now_s() - t0;
    if (sel) {
      row.params = *lensmodel_param_count(sel->chosen.model.lensmodel);
      row.rms_px = sel->chosen.rms_px;
      errors_vs_truth(truth, sel->chosen.model, &row);
      row.note = "chose " + sel->chosen.model.lensmodel;
    } else {
      row.note = "failed: " + sel.error().message;
    }
    rows.push_back(row);
  }
  const double camlab_opencv8_s = rows[3].time_s;
  if (peers) {
    rows.push_back(opencv_calibrate(data, truth, repeats));
    rows.push_back(mrcal_tool(data, truth));
  }

  std::printf(
      "| method | params | time (s) | time / camlab OPENCV8 | RMS (px) | error vs truth (px RMS, "
      "central 80%%) | HFOV error (deg) | note |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : rows) {
    std::printf("| %s | %d | %.3f | %.2f | %s | %s | %s | %s |\n", r.method.c_str(), r.params,
                r.time_s, camlab_opencv8_s > 0 ? r.time_s / camlab_opencv8_s : 0.0,
                r.rms_px >= 0 ? std::to_string(r.rms_px).substr(0, 6).c_str() : "-",
                r.diff_px >= 0 ? std::to_string(r.diff_px).substr(0, 6).c_str() : "-",
                r.fov_err_deg >= 0 ? std::to_string(r.fov_err_deg).substr(0, 6).c_str() : "-",
                r.note.c_str());
  }
  return 0;
}
