// Corner detection and the calibration it feeds, on a capture folder with the virtual
// camera's truth (`camlab render`; docs/BENCHMARKS.md). Per detector: boards found, corner
// error against the truth (RMS and max over the views found, labellings matched over the
// board's symmetries), and time per image, wall and CPU (one image at a time; OpenCV may
// use its own threads inside; reading excluded). Then
// calibrate() as `camlab calibrate --job` runs it (default detector, all cores): the
// split between reading + detection and the solve, for one model and for --model auto,
// median of --repeats runs.
//
//   calib_detect_bench --job DIR --board 14x10 --spacing-m 0.04 [--repeats 5]
//                      [--detectors saddle,opencv,mrgingham]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibrate.h"
#include "calib/corners/chessboard_detector.h"

using namespace camlab::calib;
namespace fs = std::filesystem;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CPU time of the whole process, OpenCV's own worker threads included: on a machine
// shared with other work, wall time grows with the load and CPU time much less.
double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

struct Frame {
  std::string name;
  cv::Mat image;
  nlohmann::json truth;  // corners_px, row-major; null off the imager
};

// Errors of a detection against the truth under the best of the grid's symmetries that a
// labelling may take (a half turn, mirrors; quarter turns on a square board), over the
// corners the detector placed (weight > 0).
std::vector<double> errors(const ChessboardCorners& c, const nlohmann::json& truth) {
  std::vector<double> best;
  double best_sum = 1e300;
  const int n = c.cols, m = c.rows;
  for (int g = 0; g < (n == m ? 8 : 4); ++g) {
    std::vector<double> e;
    double sum = 0;
    bool ok = true;
    for (int j = 0; j < m && ok; ++j)
      for (int i = 0; i < n && ok; ++i) {
        int ti = i, tj = j;
        if (g & 1) ti = n - 1 - ti;
        if (g & 2) tj = m - 1 - tj;
        if (g & 4) std::swap(ti, tj);
        const auto& t = truth[tj * n + ti];
        if (t.is_null()) {
          ok = false;
          break;
        }
        if (!(c.weights[j * n + i] > 0)) continue;  // left out (missing): not a position
        const double d = std::hypot(c.corners_px[j * n + i].x - t[0].get<double>(),
                                    c.corners_px[j * n + i].y - t[1].get<double>());
        e.push_back(d);
        sum += d * d;
      }
    if (ok && sum < best_sum) {
      best_sum = sum;
      best = e;
    }
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  std::string job, board = "14x10", detectors = "saddle,opencv,mrgingham";
  double spacing_m = 0.04;
  int repeats = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--job")
      job = v;
    else if (a == "--board")
      board = v;
    else if (a == "--spacing-m")
      spacing_m = std::atof(v.c_str());
    else if (a == "--repeats")
      repeats = std::max(1, std::atoi(v.c_str()));
    else if (a == "--detectors")
      detectors = v;
  }
  int cols = 0, rows = 0;
  if (job.empty() || std::sscanf(board.c_str(), "%dx%d", &cols, &rows) != 2) {
    std::fprintf(stderr, "usage: calib_detect_bench --job DIR --board CxR [--spacing-m S]\n");
    return 2;
  }
  std::vector<Frame> frames;
  for (int k = 0;; ++k) {
    char stem[64];
    std::snprintf(stem, sizeof stem, "frame_%06d", k);
    const fs::path png = fs::path(job) / (std::string(stem) + ".png");
    if (!fs::exists(png)) break;
    std::ifstream in(fs::path(job) / (std::string(stem) + ".json"));
    const auto sidecar = nlohmann::json::parse(in);
    frames.push_back({png.filename().string(), cv::imread(png.string(), cv::IMREAD_ANYDEPTH),
                      sidecar["truth"]["targets"][0]["corners_px"]});
  }
  std::printf("%zu frames of %s, %dx%d board\n\n", frames.size(), job.c_str(), cols, rows);
  std::printf("%-10s %7s %10s %8s %10s %10s %10s  %s\n", "detector", "found", "rms_px", "max_px",
              "ms/image", "cpu ms/img", "ms/miss", "missed views");
  std::stringstream list(detectors);
  for (std::string d; std::getline(list, d, ',');) {
    if (!check_chessboard_detector(d, cols, rows).ok()) continue;
    double sum_sq = 0, max_px = 0, found_s = 0, miss_s = 0, cpu_s = 0;
    int n = 0, found = 0, left_out = 0;
    std::string missed, off;  // off: views with a corner over 1 px from the truth
    for (size_t k = 0; k < frames.size(); ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = process_cpu_s();
      auto c = find_chessboard(frames[k].image, cols, rows, d);
      const double s = seconds_since(t0);
      cpu_s += process_cpu_s() - c0;
      if (!c) {
        miss_s += s;
        missed += " " + std::to_string(k);
        continue;
      }
      found_s += s;
      ++found;
      for (double w : c->weights) left_out += w > 0 ? 0 : 1;
      double view_max_px = 0;
      for (double e : errors(*c, frames[k].truth)) {
        sum_sq += e * e;
        view_max_px = std::max(view_max_px, e);
        ++n;
      }
      max_px = std::max(max_px, view_max_px);
      if (view_max_px > 1) {
        char text[48];
        std::snprintf(text, sizeof text, " %zu (%.2f px)", k, view_max_px);
        off += text;
      }
    }
    const int misses = static_cast<int>(frames.size()) - found;
    std::printf("%-10s %4d/%-2zu %10.4f %8.3f %10.1f %10.1f %s\n", d.c_str(), found, frames.size(),
                n ? std::sqrt(sum_sq / n) : 0.0, max_px, 1e3 * (found_s + miss_s) / frames.size(),
                misses ? 1e3 * miss_s / misses : 0.0, missed.c_str());
    if (!off.empty()) std::printf("%-10s views with a corner over 1 px off:%s\n", "", off.c_str());
    if (left_out > 0) std::printf("%-10s corners left out (missing): %d\n", "", left_out);
  }

  std::printf("\ncalibrate() from the folder (default detector, all cores), median of %d:\n",
              repeats);
  for (const char* model : {"LENSMODEL_OPENCV8", "auto"}) {
    std::vector<double> detect, solve, total, cpu;
    size_t views = 0;
    std::string chosen;
    for (int r = 0; r < repeats; ++r) {
      CalibrateOptions o;
      o.job_dir = job;
      o.board = {cols, rows, spacing_m};
      o.model = model;
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = process_cpu_s();
      auto run = calibrate(o);
      total.push_back(seconds_since(t0));
      cpu.push_back(process_cpu_s() - c0);
      if (!run) {
        std::printf("%s: %s\n", model, run.error().message.c_str());
        return 1;
      }
      detect.push_back(run->report_json["time_s"]["detect"].get<double>());
      solve.push_back(run->report_json["time_s"]["solve"].get<double>());
      views = run->data.views.size();
      chosen = run->report.solution.model.lensmodel;
    }
    std::printf(
        "  --model %-18s views %zu  read+detect %.2f s  solve %.2f s  total %.2f s  cpu %.2f s "
        "(%s)\n",
        model, views, median(detect), median(solve), median(total), median(cpu), chosen.c_str());
  }
  return 0;
}
