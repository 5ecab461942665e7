// The next-view suggestion (calib/view_suggestion.h) on synthetic views observed through
// a known lens (synthetic_views.h): its invariants (the board seen whole through the TRUE
// lens, a predicted improvement, and the improvement a re-solve with the view actually
// gives), the policy against random poses (guided_loop.h), and bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "calib/solver.h"
#include "calib/uncertainty.h"
#include "calib/uncertainty_update.h"
#include "calib/view_candidates.h"
#include "calib/view_suggestion.h"
#include "guided_loop.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

using testing::LoopSpec;

// Every corner of the board at rt, projected through the truth lens without noise, lies
// on the imager (observe() marks off-imager and folded-over corners missing).
bool whole_on_truth_imager(const LoopSpec& spec, const std::array<double, 6>& rt) {
  std::mt19937 rng(0);
  const BoardView v = testing::observe(spec.truth, spec.board, rt, 0, 0, rng, "check");
  return v.present_count() == spec.board.cols * spec.board.rows;
}

CalibrationData empty_session(const LoopSpec& spec) {
  CalibrationData d;
  d.board = spec.board;
  d.imager_width_px = spec.truth.width_px;
  d.imager_height_px = spec.truth.height_px;
  return d;
}

TEST(ViewSuggestion, OpeningSequenceIsSeenWholeThroughTheTrueLens) {
  const LoopSpec spec;
  CalibrationData data = empty_session(spec);
  std::mt19937 rng(3);
  for (int k = 0; k < 9; ++k) {
    auto s = suggest_next_view(data, nullptr, testing::loop_suggestion_options(spec));
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_TRUE(s->opening);
    EXPECT_EQ(s->worst_now_px, 0);
    EXPECT_NEAR(s->distance_m, spec.distance_m, 1e-9);
    EXPECT_TRUE(whole_on_truth_imager(spec, s->rt_cam_board)) << k << ": " << s->description;
    // The outline a live view draws: through the opening's pinhole a board's extreme
    // pixels are its four outer corners, so they span its bounds exactly.
    const auto& o = s->outline_px;
    EXPECT_DOUBLE_EQ(std::min({o[0], o[2], o[4], o[6]}), s->bounds_px[0]) << k;
    EXPECT_DOUBLE_EQ(std::min({o[1], o[3], o[5], o[7]}), s->bounds_px[1]) << k;
    EXPECT_DOUBLE_EQ(std::max({o[0], o[2], o[4], o[6]}), s->bounds_px[2]) << k;
    EXPECT_DOUBLE_EQ(std::max({o[1], o[3], o[5], o[7]}), s->bounds_px[3]) << k;
    EXPECT_EQ(s->imager_width_px, spec.truth.width_px);
    std::printf("  %s\n", s->description.c_str());
    data.views.push_back(testing::observe(spec.truth, spec.board, s->rt_cam_board, 0.08, 0, rng,
                                          "v" + std::to_string(k)));
  }
  // The sequence tilts the board about both axes, both ways: its views are solved.
  auto solved = testing::session_solve(data, nullptr);
  ASSERT_TRUE(solved.ok()) << solved.error().message;
  EXPECT_TRUE(solved->covariance) << solved->covariance_error;
  // With the default options (0.6 m) and the README's 14x10 board of 0.04 m too.
  LoopSpec readme;
  readme.board = {14, 10, 0.04};
  CalibrationData views = empty_session(readme);
  for (int k = 0; k < 9; ++k) {
    auto s = suggest_next_view(views, nullptr, SuggestionOptions{});
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_NEAR(s->distance_m, 0.6, 1e-9);
    EXPECT_TRUE(whole_on_truth_imager(readme, s->rt_cam_board)) << k << ": " << s->description;
    views.views.push_back(testing::observe(readme.truth, readme.board, s->rt_cam_board, 0.08, 0,
                                           rng, "r" + std::to_string(k)));
  }
}

// A session of 8 random whole-board views, then three suggestions followed: each keeps the
// board whole on the true imager, predicts an improvement, and the view observed through
// the true lens and re-solved improves the worst uncertainty by about what was predicted.
TEST(ViewSuggestion, SuggestionsAreVisibleAndImproveAsPredicted) {
  LoopSpec spec;
  testing::ViewSetSpec draw;
  draw.views = 8;
  draw.noise_px = spec.noise_px;
  draw.keep_partial = false;
  draw.seed = 5;
  CalibrationData data = testing::make_views(spec.truth, spec.board, draw);
  ASSERT_EQ(data.views.size(), 8u);
  auto solution = testing::session_solve(data, nullptr);
  ASSERT_TRUE(solution.ok()) << solution.error().message;
  const SuggestionOptions options = testing::loop_suggestion_options(spec);
  std::mt19937 rng(17);
  for (int step = 0; step < 3; ++step) {
    auto s = suggest_next_view(data, &*solution, options);
    ASSERT_TRUE(s.ok()) << s.error().message;
    std::printf("  %s\n", s->description.c_str());
    EXPECT_FALSE(s->opening);
    EXPECT_TRUE(whole_on_truth_imager(spec, s->rt_cam_board));
    EXPECT_GT(s->worst_now_px, 0);
    EXPECT_LT(s->predicted_worst_px, s->worst_now_px);
    EXPECT_LE(std::fabs(s->tilt_about_x_deg), options.max_tilt_deg + 1e-9);
    EXPECT_LE(std::fabs(s->tilt_about_y_deg), options.max_tilt_deg + 1e-9);
    EXPECT_GE(s->bounds_px[0], 0);
    EXPECT_GE(s->bounds_px[1], 0);
    EXPECT_LE(s->bounds_px[2], spec.truth.width_px - 1);
    EXPECT_LE(s->bounds_px[3], spec.truth.height_px - 1);
    data.views.push_back(testing::observe(spec.truth, spec.board, s->rt_cam_board, spec.noise_px, 0,
                                          rng, "s" + std::to_string(step)));
    auto next = testing::session_solve(data, &*solution);
    ASSERT_TRUE(next.ok()) << next.error().message;
    auto now = uncertainty_coverage(*next, options);
    ASSERT_TRUE(now.ok()) << now.error().message;
    const double achieved = s->worst_now_px - now->worst_of_grid_px;
    const double predicted = s->worst_now_px - s->predicted_worst_px;
    std::printf("    worst %.4f -> predicted %.4f, after the re-solve %.4f px\n", s->worst_now_px,
                s->predicted_worst_px, now->worst_of_grid_px);
    // The prediction linearises at the current optimum with the current sigma estimate;
    // the re-solve moves both: sigma by its sampling error (~2-3% over 600-1300
    // residuals, scaling every value alike) and the lens by up to the current
    // uncertainty, which changes the derivatives the prediction used. From a poorly
    // known lens (tens of px at the imager's corners) that allows 25%; once the worst is
    // under 2 px the lens moves by a fraction of a px and 10% holds.
    const double ratio = now->worst_of_grid_px / s->predicted_worst_px;
    EXPECT_NEAR(ratio, 1.0, s->worst_now_px > 2 ? 0.25 : 0.10);
    EXPECT_GT(achieved, 0.5 * predicted);
    solution = std::move(next);
  }
}

// Views until the worst of the grid at 0.7 m falls below 0.5 px: the guided loop against
// poses drawn as ViewSetSpec draws them (whole boards, as a chessboard detector needs;
// 0.4-1.0 m, tilts up to 40 deg, centres over the central 90%), median over 10 seeds,
// each run capped at 30 views to keep the test near 10 s (the benchmark caps at 60). The corner
// noise, 0.08 px, is about what camlab's saddle detector has on the virtual camera's boards; the
// guided loop needs 5-7 views with it, so the count is not decided by the opening alone. Random
// poses rarely put a whole board near the imager's corners, where the worst uncertainty is: they
// mostly end at the cap, which makes "half of random" a bound, not a ratio.
TEST(ViewSuggestion, GuidedLoopNeedsAtMostHalfTheViewsOfRandomPoses) {
  std::vector<int> guided, random;
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    LoopSpec spec;
    spec.seed = seed;
    spec.max_views = 30;
    const auto g = testing::run_guided(spec);
    const auto r = testing::run_random(spec);
    std::printf("  seed %2u: guided %2d views (worst %.3f px), random %2d views (worst %.3f px)\n",
                seed, g.views, g.worst_px, r.views, r.worst_px);
    EXPECT_TRUE(g.reached) << seed;
    guided.push_back(g.views);
    random.push_back(r.reached ? r.views : spec.max_views);
    // The claim is the truth's: the guided lens projects like the true one everywhere on
    // the imager (best-aligning rotation, as mrcal's projection_diff) to within 4 times
    // the worst stdev it reports (1600 samples of a smooth field: not a 1-sigma bound).
    ASSERT_TRUE(g.solution);
    auto diff = projection_difference(spec.truth, g.solution->model, 1.0, 40, true);
    ASSERT_TRUE(diff.ok()) << diff.error().message;
    EXPECT_LT(diff->max_px, 4 * g.worst_px) << seed << ": " << diff->max_px << " px";
  }
  std::sort(guided.begin(), guided.end());
  std::sort(random.begin(), random.end());
  // The median of 10: the mean of the 5th and 6th.
  const double guided_median = 0.5 * (guided[4] + guided[5]);
  const double random_median = 0.5 * (random[4] + random[5]);
  std::printf("  median: guided %.1f, random %.1f views\n", guided_median, random_median);
  EXPECT_LE(2 * guided_median, random_median);
}

// A ChArUco board is found from part of it: with whole_board_required off, a candidate
// may reach past the imager's edge as long as half its corners stay on it.
TEST(ViewSuggestion, PartialBoardsKeepHalfTheCornersOnTheImager) {
  LoopSpec spec;
  testing::ViewSetSpec draw;
  draw.views = 10;
  draw.noise_px = spec.noise_px;
  draw.seed = 4;
  CalibrationData data = testing::make_views(spec.truth, spec.board, draw);
  auto s = testing::session_solve(data, nullptr);
  ASSERT_TRUE(s.ok()) << s.error().message;
  SuggestionOptions o = testing::loop_suggestion_options(spec);
  o.whole_board_required = false;
  auto next = suggest_next_view(data, &*s, o);
  ASSERT_TRUE(next.ok()) << next.error().message;
  std::printf("  %s\n", next->description.c_str());
  std::mt19937 rng(0);
  const BoardView v = testing::observe(spec.truth, spec.board, next->rt_cam_board, 0, 0, rng, "c");
  // Half through the current model; the truth differs from it by the uncertainty (px).
  EXPECT_GE(2 * v.present_count() + 4, spec.board.cols * spec.board.rows);
  EXPECT_LT(next->predicted_worst_px, next->worst_now_px);
}

TEST(ViewSuggestion, BadInputIsRefused) {
  const LoopSpec spec;
  const SuggestionOptions ok = testing::loop_suggestion_options(spec);
  CalibrationData empty;  // no board, no imager
  auto e = suggest_next_view(empty, nullptr, ok);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidArgument);

  CalibrationData data = empty_session(spec);
  auto bad = [&](SuggestionOptions o) {
    auto r = suggest_next_view(data, nullptr, o);
    return !r.ok() && r.error().code == ErrorCode::kInvalidArgument;
  };
  SuggestionOptions o = ok;
  o.grid_cols = 1;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.grid_rows = 1000;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.max_tilt_deg = 80;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.max_tilt_deg = -1;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.distance_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(bad(o));
  o = ok;
  o.nominal_fov_x_deg = 0;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.opening_distance_m = 0;
  EXPECT_TRUE(bad(o));
  o = ok;
  o.min_corner_margin_px = 500;
  EXPECT_TRUE(bad(o));

  // A board of 10 x 7 corners 0.2 m apart (1.8 m wide) cannot be seen whole at 0.7 m.
  CalibrationData huge = data;
  huge.board.spacing_m = 0.2;
  auto opening = suggest_next_view(huge, nullptr, ok);
  ASSERT_FALSE(opening.ok());
  EXPECT_EQ(opening.error().code, ErrorCode::kNoCandidate) << opening.error().message;

  // With a solution: the same board too large at the asked distance, and a solution
  // without a covariance.
  testing::ViewSetSpec draw;
  draw.views = 6;
  draw.noise_px = 0.08;
  draw.keep_partial = false;
  CalibrationData views = testing::make_views(spec.truth, spec.board, draw);
  auto solved = testing::session_solve(views, nullptr);
  ASSERT_TRUE(solved.ok()) << solved.error().message;
  SuggestionOptions near = ok;
  near.distance_m = 0.1;  // the 0.45 m board fills far more than the imager at 0.1 m
  auto none = suggest_next_view(views, &*solved, near);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::kNoCandidate) << none.error().message;
  Solution no_cov = *solved;
  no_cov.covariance.reset();
  auto nc = suggest_next_view(views, &no_cov, ok);
  ASSERT_FALSE(nc.ok());
  EXPECT_EQ(nc.error().code, ErrorCode::kNoCovariance);
  EXPECT_FALSE(uncertainty_coverage(no_cov, ok).ok());
  // A solution of other data (another board) is refused, never read out of bounds.
  CalibrationData other = views;
  other.board.cols = 9;
  auto mismatch = suggest_next_view(other, &*solved, ok);
  ASSERT_FALSE(mismatch.ok());
  EXPECT_EQ(mismatch.error().code, ErrorCode::kInvalidArgument);
}

// The suggestion scores a candidate without re-solving: the solved problem's information
// plus the candidate's own rows, propagated through [intrinsics, the reference frame's
// motion] (uncertainty_update.h). That must equal the full definition: mrcal's callback on
// the problem with the candidate appended, the covariance formula, the mean-frames
// projection of projection_uncertainty, over the whole grid.
TEST(ViewSuggestion, PredictionEqualsTheUncertaintyOfTheProblemWithTheViewAppended) {
  const LoopSpec spec;
  testing::ViewSetSpec draw;
  draw.views = 8;
  draw.noise_px = 0.08;
  draw.keep_partial = false;
  draw.seed = 9;
  CalibrationData data = testing::make_views(spec.truth, spec.board, draw);
  auto s = testing::session_solve(data, nullptr);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->covariance);
  auto predictor = UncertaintyPredictor::make(data, *s);
  ASSERT_TRUE(predictor.ok()) << predictor.error().message;
  const SuggestionOptions options = testing::loop_suggestion_options(spec);
  std::vector<std::array<double, 3>> points;
  for (double fy : {0.0, 0.3, 1.0})
    for (double fx : {0.0, 0.5, 0.9}) {
      auto dir = unproject(s->model, {fx * 1279, fy * 799});
      ASSERT_TRUE(dir.ok());
      points.push_back({(*dir)[0] * 0.7, (*dir)[1] * 0.7, (*dir)[2] * 0.7});
    }
  int compared = 0;
  for (auto [gx, gy, tx, ty] :
       {std::array<double, 4>{-1, -1, 0, 40}, {1, 0, -40, 0}, {0, 0, 0, 0}}) {
    auto c = place_towards(s->model, data.board, s->calobject_warp, static_cast<int>(gx),
                           static_cast<int>(gy), 0.7, tx, ty, options);
    ASSERT_TRUE(c);
    const AddedView added{c->rt_cam_board, c->corners_px, c->visible};
    auto predicted = predictor->worst_px_with(added, points);
    ASSERT_TRUE(predicted.ok()) << predicted.error().message;
    mrcal_problem_selections_t sel;
    auto problem = solved_problem(data, *s, &added, &sel);
    ASSERT_TRUE(problem.ok()) << problem.error().message;
    std::vector<char> downweighted = s->view_downweighted;
    downweighted.push_back(0);
    auto cov = state_covariance(*problem, data.board, sel, downweighted);
    ASSERT_TRUE(cov.ok()) << cov.error().message;
    Solution with;
    with.model = s->model;
    with.rt_cam_board = s->rt_cam_board;
    with.rt_cam_board.push_back(c->rt_cam_board);
    with.covariance = std::make_shared<const StateCovariance>(std::move(*cov));
    for (size_t i = 0; i < points.size(); ++i) {
      auto full =
          projection_uncertainty_of_point(with, points[i], false, s->covariance->observed_sigma_px);
      ASSERT_TRUE(full.ok()) << full.error().message;
      // Equal but for rounding: two different factorisations of J^T J (a Cholesky solve
      // against a Cholesky inverse) differ from the 6th digit on.
      EXPECT_NEAR((*predicted)[i] / full->worst_px(), 1.0, 1e-5) << i;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 27);
}

TEST(ViewSuggestion, CoverageIsTheUncertaintyGrid) {
  const LoopSpec spec;
  testing::ViewSetSpec draw;
  draw.views = 10;
  draw.noise_px = 0.08;
  draw.keep_partial = false;
  CalibrationData views = testing::make_views(spec.truth, spec.board, draw);
  auto s = testing::session_solve(views, nullptr);
  ASSERT_TRUE(s.ok()) << s.error().message;
  SuggestionOptions o;
  o.grid_cols = 5;
  o.grid_rows = 4;
  o.distance_m = 0.6;
  auto cov = uncertainty_coverage(*s, o);
  ASSERT_TRUE(cov.ok()) << cov.error().message;
  auto grid = uncertainty_grid(*s, 5, 4, 0.6);
  ASSERT_TRUE(grid.ok());
  ASSERT_EQ(cov->worst_px.size(), grid->size());
  double worst = 0;
  for (size_t i = 0; i < grid->size(); ++i) {
    EXPECT_NEAR(cov->worst_px[i], (*grid)[i], 1e-9 * (*grid)[i]) << i;
    worst = std::max(worst, (*grid)[i]);
  }
  EXPECT_EQ(cov->worst_of_grid_px, worst);
  auto at = projection_uncertainty(*s, cov->worst_x_px, cov->worst_y_px, 0.6);
  ASSERT_TRUE(at.ok());
  EXPECT_NEAR(at->worst_px(), worst, 1e-9 * worst);
}

}  // namespace
}  // namespace camlab::calib
