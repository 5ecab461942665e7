// sfr_compare_bench: camlab's slanted-edge SFR beside a public SFR tool, MTF Mapper
// (Frans van den Bergh, BSD licence, built from its own source: docs/analysis.md says how),
// on the same edges: tests/unit/analysis/sfr_edges.h's analytic Gaussian (sigma 0.45-1.6
// px) and disk (1.5-5 px) edges, 5 angles from 2.5 to 20 deg off the columns and rows,
// 8 x 8 samples a pixel, then its 40 sharp ones (sigma 0.1-0.35 px, MTF50 0.41-0.59
// cycles/px), written as 16-bit PNGs (both tools read the same files), without noise and
// at contrast-to-noise 50 (SEEDS noise draws of each). MTF Mapper reads each image as one
// region (--single-roi); camlab measures the segment through the centre the unit tests use
// (120 px along it) and the whole edge. Prints each tool's MTF50 error against the
// closed-form truth: p95 over the edges whose truth lies in 0.2-0.3 cycles/px, p95 and
// worst over all, the mean (bias), and the time per edge (camlab: the SFR call; MTF
// Mapper: the whole process, start-up included).
//
//   sfr_compare_bench MTF_MAPPER [SEEDS=4] [WORKDIR=/tmp/camlab_sfr_compare] [steep]
//
// MTF_MAPPER "-": camlab alone. "steep": the 90 edges at 24-30 deg instead (sfr_edges.h).
//
// Not run by ctest: MTF Mapper is not a Debian package.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../unit/analysis/sfr_edges.h"
#include "analysis/sfr/slanted_edge_sfr.h"

namespace {

using namespace camlab::analysis;
using namespace camlab::analysis::sfr_edges;
namespace fs = std::filesystem;

struct Tally {
  std::vector<double> near_quarter, all, signed_all, seconds;
  int failed = 0;
  void add(double measured, double truth, double seconds_taken) {
    const double error = measured / truth - 1;
    all.push_back(std::fabs(error));
    signed_all.push_back(error);
    if (truth >= 0.2 && truth <= 0.3) near_quarter.push_back(std::fabs(error));
    seconds.push_back(seconds_taken);
  }
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::ceil(p * v.size()) - 1))];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x / static_cast<double>(v.size());
  return v.empty() ? NAN : s;
}

// MTF Mapper's MTF50 (cycles/px) of the one edge in `png`: the first data row of its
// edge_mtf_values.txt (column 4), none when it found no edge.
std::optional<double> mtf_mapper_mtf50(const std::string& binary, const fs::path& png,
                                       const fs::path& out_dir) {
  fs::remove_all(out_dir);
  fs::create_directories(out_dir);
  const std::string command = "'" + binary + "' -q -v 2 --single-roi '" + png.string() + "' '" +
                              out_dir.string() + "' --logfile '" + (out_dir / "log.txt").string() +
                              "' > /dev/null 2>&1";
  if (std::system(command.c_str()) != 0) return std::nullopt;
  std::ifstream in(out_dir / "edge_mtf_values.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double block = 0, x = 0, y = 0, mtf50 = 0;
    if (fields >> block >> x >> y >> mtf50) return mtf50;
  }
  return std::nullopt;
}

void print_row(const char* tool, const char* noise, const Tally& t) {
  std::printf("| %s | %s | %zu | %.2f%% | %.2f%% | %.2f%% | %+.2f%% | %.2f ms | %d |\n", tool,
              noise, t.all.size(), 100 * percentile(t.near_quarter, 0.95),
              100 * percentile(t.all, 0.95), 100 * percentile(t.all, 1.0), 100 * mean(t.signed_all),
              1e3 * mean(t.seconds), t.failed);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: %s MTF_MAPPER [SEEDS=4] [WORKDIR=/tmp/camlab_sfr_compare] [steep]\n",
                 argv[0]);
    return 2;
  }
  const std::string binary = argv[1];
  const int seeds = argc > 2 ? std::clamp(std::atoi(argv[2]), 1, 100) : 4;
  const fs::path work = argc > 3 ? fs::path(argv[3]) : fs::path("/tmp/camlab_sfr_compare");
  const bool steep = argc > 4 && std::string(argv[4]) == "steep";
  const std::vector<TestEdge> standard =
      steep ? test_edges({24.0, 26.0, 26.5, 27.0, 30.0}) : test_edges();
  fs::create_directories(work);
  cv::setNumThreads(1);
  std::printf(
      "| tool | noise | edges | p95, truth 0.2-0.3 cy/px | p95, all | worst | mean (bias) | time "
      "per edge | not measured |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const bool sharp : {false, true})
    for (double cnr : {0.0, 50.0}) {
      Tally camlab, camlab_whole, mapper;
      unsigned seed = 1;
      for (int draw = 0; draw < (cnr > 0 ? seeds : 1); ++draw)
        for (const auto& [optics, angle, turned] : sharp ? sharp_edges() : standard) {
          const double truth = true_mtf50(optics, angle);
          cv::Mat drawn = draw_edge(optics, angle, turned, seed++, cnr), image16;
          drawn.convertTo(image16, CV_16U);
          const fs::path png = work / "edge.png";
          cv::imwrite(png.string(), image16);
          // camlab on the PNG as written (the same quantised values MTF Mapper reads).
          const cv::Mat read = cv::imread(png.string(), cv::IMREAD_UNCHANGED);
          auto t0 = std::chrono::steady_clock::now();
          const auto r = slanted_edge_sfr(read, centre_segment(angle, turned));
          const double camlab_s =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (r.ok() && r->status == "ok" && r->mtf50_cy_px)
            camlab.add(*r->mtf50_cy_px, truth, camlab_s);
          else
            ++camlab.failed;
          // The whole edge, as MTF Mapper reads it: every row of the image.
          const auto whole = slanted_edge_sfr(
              read, centre_segment(angle, turned, 0.5 * kSize / std::cos(angle * kPi / 180)));
          if (whole.ok() && whole->status == "ok" && whole->mtf50_cy_px)
            camlab_whole.add(*whole->mtf50_cy_px, truth, camlab_s);
          else
            ++camlab_whole.failed;
          t0 = std::chrono::steady_clock::now();
          const auto m =
              binary == "-" ? std::nullopt : mtf_mapper_mtf50(binary, png, work / "mtf_mapper");
          const double mapper_s =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (m)
            mapper.add(*m, truth, mapper_s);
          else
            ++mapper.failed;
        }
      const std::string noise = std::string(cnr > 0 ? "CNR 50" : "none") + (sharp ? ", sharp" : "");
      print_row("camlab, 120 px of the edge", noise.c_str(), camlab);
      print_row("camlab, the whole edge", noise.c_str(), camlab_whole);
      print_row("MTF Mapper", noise.c_str(), mapper);
    }
  return 0;
}
