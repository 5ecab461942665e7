// guided_calibration_bench: views needed until the worst projection uncertainty over the
// imager (16 x 10 grid, at the working distance) falls below a target, for the guided
// loop (each view placed at the suggestion, calib/view_suggestion.h) against random
// poses (ViewSetSpec's draw), on synthetic views through the OPENCV8 wide truth
// (tests/unit/calib/guided_loop.h), per seed and as the median; and the time of a
// suggestion against the number of views in the solve.
//
//   guided_calibration_bench [--seeds N] [--cap VIEWS] [--noise PX] [--target PX]
//                            [--distance M]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "guided_loop.h"

namespace {

using namespace camlab::calib;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A solve of `views` random whole-board views, then --repeats suggestions timed.
void time_suggestions(const testing::LoopSpec& base, int views) {
  testing::ViewSetSpec draw;
  draw.views = views;
  draw.noise_px = base.noise_px;
  draw.keep_partial = false;
  draw.seed = 100 + views;
  const CalibrationData data = testing::make_views(base.truth, base.board, draw);
  auto s = testing::session_solve(data, nullptr);
  if (!s || !s->covariance) {
    std::printf("| %d | (no solve) | | |\n", views);
    return;
  }
  std::vector<double> t;
  for (int k = 0; k < 5; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    auto next = suggest_next_view(data, &*s, testing::loop_suggestion_options(base));
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (!next) {
      std::printf("| %d | error %s | | |\n", views, next.error().message.c_str());
      return;
    }
  }
  std::printf("| %d | %.1f | %.1f | %.1f |\n", views, 1e3 * median(t),
              1e3 * *std::min_element(t.begin(), t.end()),
              1e3 * *std::max_element(t.begin(), t.end()));
}

}  // namespace

int main(int argc, char** argv) {
  testing::LoopSpec base;
  base.max_views = 60;
  int seeds = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const double v = std::atof(argv[i + 1]);
    if (a == "--seeds")
      seeds = std::max(1, static_cast<int>(v));
    else if (a == "--cap")
      base.max_views = std::max(3, static_cast<int>(v));
    else if (a == "--noise")
      base.noise_px = v;
    else if (a == "--target")
      base.target_px = v;
    else if (a == "--distance")
      base.distance_m = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  std::printf(
      "10x7 board 0.05 m, OPENCV8 wide truth 1280x800, noise %.3f px, target %.3f px worst "
      "at %.2f m, cap %d views\n\n",
      base.noise_px, base.target_px, base.distance_m, base.max_views);
  std::printf(
      "| seed | guided views | guided worst px | suggestion median ms | suggestion max ms | "
      "random views (whole boards) | its worst px | random views (partial boards kept) | "
      "its worst px |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  std::vector<double> guided, random_whole, random_partial, all_suggest;
  auto shown = [&](const testing::LoopResult& r) {
    return r.reached ? std::to_string(r.views) : ">" + std::to_string(r.views);
  };
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::LoopSpec spec = base;
    spec.seed = static_cast<uint32_t>(seed);
    const auto g = testing::run_guided(spec);
    const auto r = testing::run_random(spec);
    spec.random_partial = true;
    const auto p = testing::run_random(spec);
    all_suggest.insert(all_suggest.end(), g.suggest_s.begin(), g.suggest_s.end());
    std::printf(
        "| %d | %s | %.3f | %.1f | %.1f | %s | %.3f | %s | %.3f |\n", seed, shown(g).c_str(),
        g.worst_px, 1e3 * median(g.suggest_s),
        g.suggest_s.empty() ? 0.0 : 1e3 * *std::max_element(g.suggest_s.begin(), g.suggest_s.end()),
        shown(r).c_str(), r.worst_px, shown(p).c_str(), p.worst_px);
    std::fflush(stdout);
    guided.push_back(g.views);
    random_whole.push_back(r.views);
    random_partial.push_back(p.views);
  }
  std::printf("| median | %.1f | | %.1f | | %.1f | | %.1f | |\n\n", median(guided),
              1e3 * median(all_suggest), median(random_whole), median(random_partial));
  std::printf("Suggestion time against the views in the solve (5 repeats):\n\n");
  std::printf("| views | median ms | min ms | max ms |\n|---:|---:|---:|---:|\n");
  for (int views : {5, 10, 20, 40}) time_suggestions(base, views);
  return 0;
}
