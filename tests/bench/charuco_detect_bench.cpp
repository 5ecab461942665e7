// ChArUco corners against the virtual camera's truth (`camlab render` of a ChArUco scene;
// docs/BENCHMARKS.md): for each stage of calib/corners/charuco_corners.h, the corner error
// against the truth, RMS and max, over all corners and over those within --border-px of
// the imager's border, on the corners every stage has (the refined ones); the corners
// named, the ids that disagree with the truth's nearest corner, the corners dropped and
// why, and the time per image. Then what each stage's corners make of the lens: an
// OPENCV8 solve (calib/solver.h) on the same corners of the same views, compared with the
// truth's lens by projection (each pixel of a 33 x 21 grid unprojected through the truth,
// projected through the solve), over the whole imager and its central 60%.
//
//   charuco_detect_bench --job DIR --squares 11x8 --square-m 0.06 --marker-m 0.045
//                        --dictionary DICT_4X4_50 [--border-px 50]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/corners/charuco_corners.h"
#include "calib/library_stderr.h"
#include "calib/mrcal_api.h"
#include "calib/solver.h"

using namespace camlab::calib;
namespace fs = std::filesystem;

namespace {

struct Errors {
  std::vector<double> all, border;
  cv::Point2d sum;  // of the signed errors: a shared offset is a bias, not noise
  void add(cv::Point2d e, bool near_border) {
    all.push_back(cv::norm(e));
    if (near_border) border.push_back(cv::norm(e));
    sum += e;
  }
  cv::Point2d mean() const { return all.empty() ? sum : sum / static_cast<double>(all.size()); }
};

double rms(const std::vector<double>& e) {
  double s = 0;
  for (double x : e) s += x * x;
  return e.empty() ? 0 : std::sqrt(s / e.size());
}

double max_of(const std::vector<double>& e) {
  return e.empty() ? 0 : *std::max_element(e.begin(), e.end());
}

// The solved lens against the truth's, by projection: RMS over the imager and its
// central 60% (px).
std::pair<double, double> lens_error_px(const LensModel& fitted, const nlohmann::json& truth) {
  const std::vector<double> truth_intrinsics = truth["intrinsics"];
  const int width = truth["imagersize"][0], height = truth["imagersize"][1];
  mrcal_lensmodel_t truth_lens, fitted_lens;
  mrcal_lensmodel_from_name(&truth_lens, truth["lensmodel"].get<std::string>().c_str());
  mrcal_lensmodel_from_name(&fitted_lens, fitted.lensmodel.c_str());
  double all = 0, centre = 0;
  int n = 0, n_centre = 0;
  for (int y = 0; y <= 20; ++y)
    for (int x = 0; x <= 32; ++x) {
      const mrcal_point2_t q = {.x = x * (width - 1) / 32.0, .y = y * (height - 1) / 20.0};
      mrcal_point3_t v;
      mrcal_point2_t back;
      if (!mrcal_unproject(&v, &q, 1, &truth_lens, truth_intrinsics.data()) ||
          !mrcal_project(&back, nullptr, nullptr, &v, 1, &fitted_lens, fitted.intrinsics.data()))
        continue;
      const double e2 = (back.x - q.x) * (back.x - q.x) + (back.y - q.y) * (back.y - q.y);
      all += e2;
      ++n;
      if (std::fabs(q.x - (width - 1) / 2.0) <= 0.3 * width &&
          std::fabs(q.y - (height - 1) / 2.0) <= 0.3 * height) {
        centre += e2;
        ++n_centre;
      }
    }
  return {std::sqrt(all / std::max(1, n)), std::sqrt(centre / std::max(1, n_centre))};
}

double percentile(std::vector<double> e, double p) {
  if (e.empty()) return 0;
  std::sort(e.begin(), e.end());
  return e[static_cast<size_t>(p * (e.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  std::string job, squares = "11x8", dictionary = "DICT_4X4_50";
  double square_m = 0.06, marker_m = 0.045, border_px = 50;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--job")
      job = v;
    else if (a == "--squares")
      squares = v;
    else if (a == "--square-m")
      square_m = std::atof(v.c_str());
    else if (a == "--marker-m")
      marker_m = std::atof(v.c_str());
    else if (a == "--dictionary")
      dictionary = v;
    else if (a == "--border-px")
      border_px = std::atof(v.c_str());
  }
  CharucoBoardSpec board;
  board.square_m = square_m;
  board.marker_m = marker_m;
  board.dictionary = dictionary;
  if (job.empty() ||
      std::sscanf(squares.c_str(), "%dx%d", &board.squares_cols, &board.squares_rows) != 2) {
    std::fprintf(stderr,
                 "usage: charuco_detect_bench --job DIR --squares CxR --square-m S --marker-m M "
                 "--dictionary NAME [--border-px 50]\n");
    return 2;
  }
  if (auto s = check_charuco_board(board); !s) {
    std::fprintf(stderr, "%s\n", s.error().message.c_str());
    return 2;
  }
  constexpr int kStages = 4;
  const char* stage_names[kStages] = {
      "homography (marker homographies, no image refinement)",
      "OpenCV interpolateCornersCharuco (homography + cornerSubPix)",
      "  the same, OpenCV 4.6's +0.5 px shift undone", "camlab saddle point"};
  Errors errors[kStages];
  // Per stage, the views' corners for a solve: the refined ones, at each stage's position.
  CalibrationData data[kStages];
  nlohmann::json truth_of_first;
  int frames = 0, views_with_corners = 0, named = 0, refined = 0, truth_visible = 0;
  int wrong_ids = 0, border_truth = 0;
  double seconds = 0;
  std::vector<double> window_px;
  std::map<std::string, int> dropped_because;  // the reason, its numbers cut off
  for (int k = 0;; ++k) {
    char stem[64];
    std::snprintf(stem, sizeof stem, "frame_%06d", k);
    const fs::path png = fs::path(job) / (std::string(stem) + ".png");
    if (!fs::exists(png)) break;
    ++frames;
    std::ifstream in(fs::path(job) / (std::string(stem) + ".json"));
    const auto sidecar = nlohmann::json::parse(in);
    const auto& truth = sidecar["truth"]["targets"][0]["corners_px"];
    const int width = sidecar["truth"]["imagersize"][0], height = sidecar["truth"]["imagersize"][1];
    auto near_border = [&](double x, double y) {
      return x < border_px || y < border_px || x > width - 1 - border_px ||
             y > height - 1 - border_px;
    };
    for (const auto& t : truth)
      if (!t.is_null()) {
        ++truth_visible;
        border_truth += near_border(t[0], t[1]) ? 1 : 0;
      }
    if (truth_of_first.is_null()) truth_of_first = sidecar["truth"];
    const cv::Mat image = cv::imread(png.string(), cv::IMREAD_ANYDEPTH);
    const auto t0 = std::chrono::steady_clock::now();
    auto d = detect_charuco(image, board);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!d) {
      std::fprintf(stderr, "%s: %s\n", stem, d.error().message.c_str());
      return 1;
    }
    named += static_cast<int>(d->corners.size());
    BoardView views[kStages];
    for (BoardView& v : views) {
      v.name = png.filename().string();
      v.corners.assign(static_cast<size_t>(d->cols * d->rows), CornerObservation{});
    }
    views_with_corners += d->corners.empty() ? 0 : 1;
    for (const auto& c : d->corners) {
      const auto& t = truth[static_cast<size_t>(c.id)];
      // An id is right when the truth puts that corner nearest to where it was found.
      size_t nearest = 0;
      double best = 1e300;
      for (size_t i = 0; i < truth.size(); ++i) {
        if (truth[i].is_null()) continue;
        const double e = std::hypot(c.opencv_px.x - truth[i][0].get<double>(),
                                    c.opencv_px.y - truth[i][1].get<double>());
        if (e < best) best = e, nearest = i;
      }
      if (t.is_null() || nearest != static_cast<size_t>(c.id)) {
        ++wrong_ids;
        continue;
      }
      if (!c.saddle_px) {
        ++dropped_because[c.dropped_because.substr(0,
                                                   c.dropped_because.find_first_of("0123456789"))];
        continue;
      }
      ++refined;
      window_px.push_back(c.window_px);
      const cv::Point2d truth_px(t[0].get<double>(), t[1].get<double>());
      const bool b = near_border(truth_px.x, truth_px.y);
      errors[0].add(c.homography_px - truth_px, b);
      errors[1].add(c.opencv_px - truth_px, b);
      errors[2].add(c.opencv_px - cv::Point2d(0.5, 0.5) - truth_px, b);
      errors[3].add(*c.saddle_px - truth_px, b);
      const cv::Point2d at[kStages] = {c.homography_px, c.opencv_px,
                                       c.opencv_px - cv::Point2d(0.5, 0.5), *c.saddle_px};
      for (int s = 0; s < kStages; ++s)
        views[s].corners[static_cast<size_t>(c.id)] = {at[s].x, at[s].y, 1.0, true};
    }
    for (int s = 0; s < kStages; ++s)
      if (views[s].present_count() > 0) data[s].views.push_back(views[s]);
  }
  {
    const auto& size = truth_of_first["imagersize"];
    for (CalibrationData& c : data) {
      c.board = {board.squares_cols - 1, board.squares_rows - 1, board.square_m};
      c.imager_width_px = size[0];
      c.imager_height_px = size[1];
    }
  }
  std::printf("%d frames of %s: %d truth corners on the imager (%d within %g px of the border)\n",
              frames, job.c_str(), truth_visible, border_truth, border_px);
  std::printf(
      "views with corners %d; corners named by OpenCV %d, wrong ids %d; refined %d "
      "(dropped %d); saddle window radius median %.1f px (5%% %.1f, 95%% %.1f)\n\n",
      views_with_corners, named, wrong_ids, refined, named - wrong_ids - refined,
      percentile(window_px, 0.5), percentile(window_px, 0.05), percentile(window_px, 0.95));
  for (const auto& [why, n] : dropped_because)
    std::printf("  dropped %4d: %s...\n", n, why.c_str());
  std::printf("\n%-62s %9s %8s %8s %15s | %9s %8s %8s\n", "stage (the refined corners)", "rms_px",
              "max_px", "n", "mean dx,dy px", "border rms", "max_px", "n");
  for (int s = 0; s < kStages; ++s)
    std::printf("%-62s %9.4f %8.3f %8zu %7.3f,%7.3f | %9.4f %8.3f %8zu\n", stage_names[s],
                rms(errors[s].all), max_of(errors[s].all), errors[s].all.size(), errors[s].mean().x,
                errors[s].mean().y, rms(errors[s].border), max_of(errors[s].border),
                errors[s].border.size());
  std::printf("\ndetection time %.1f ms per image (wall, one image at a time)\n",
              1e3 * seconds / std::max(1, frames));

  std::printf("\nLENSMODEL_OPENCV8 solved on each stage's corners, against the truth's lens:\n");
  std::printf("%-62s %12s %14s %14s %10s\n", "stage", "residual rms", "lens rms px", "central 60%",
              "outliers");
  const LibraryStderrCapture quiet_mrcal;  // mrcal's progress lines go to the log
  for (int s = 0; s < kStages; ++s) {
    SolveOptions options;
    options.lensmodel = "LENSMODEL_OPENCV8";
    options.compute_covariance = false;
    auto solution = solve(data[s], options);
    if (!solution) {
      std::printf("%-62s %s\n", stage_names[s], solution.error().message.c_str());
      continue;
    }
    const auto [all, centre] = lens_error_px(solution->model, truth_of_first);
    int outliers = 0;
    double sum_sq = 0;
    int n = 0;
    for (const auto& r : solution->residuals) {
      if (r.outlier) {
        ++outliers;
        continue;
      }
      sum_sq += r.dx_px * r.dx_px + r.dy_px * r.dy_px;
      ++n;
    }
    std::printf("%-62s %12.4f %14.4f %14.4f %10d\n", stage_names[s],
                std::sqrt(sum_sq / std::max(1, n)), all, centre, outliers);
  }
  return 0;
}
