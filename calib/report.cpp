#include "calib/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/calib3d.hpp>

#include "base/format.h"
#include "calib/library_stderr.h"
#include "optics/optics.h"

namespace camlab::calib {

namespace {

constexpr double kDeg = 180.0 / M_PI;

}  // namespace

CalibrationReport make_report(const CalibrationData& data, const Solution& s,
                              double pixel_pitch_um) {
  const LibraryStderrCapture quiet_mrcal;  // the uncertainty calls into mrcal
  CalibrationReport r;
  r.solution = s;
  r.views_total = static_cast<int>(data.views.size());
  const int total = s.inliers + s.outliers;
  double sum_w2 = 0;
  for (const auto& res : s.residuals) {
    if (res.outlier) continue;
    const double w = data.views[res.view].corners[res.corner].weight;
    sum_w2 += w * w * (res.dx_px * res.dx_px + res.dy_px * res.dy_px);
  }
  r.rms_weighted_px = std::sqrt(sum_w2 / std::max(1, s.inliers));
  r.outlier_share = total > 0 ? double(s.outliers) / total : 0.0;
  auto fov = field_of_view_parts(s.model);
  if (fov) r.fov = *fov;
  if (auto sigma = intrinsics_uncertainty(s); sigma.ok()) r.intrinsics_sigma = *sigma;

  if (pixel_pitch_um > 0) {
    r.pixel_pitch_um = pixel_pitch_um;
    r.focal_mm = 0.5 * (s.model.intrinsics[0] + s.model.intrinsics[1]) * pixel_pitch_um / 1000;
    const double w_mm = data.imager_width_px * pixel_pitch_um / 1000;
    const double h_mm = data.imager_height_px * pixel_pitch_um / 1000;
    if (auto crop = optics::crop_factor(w_mm, h_mm); crop.ok()) {
      r.crop_factor = *crop;
      r.focal_35mm_equiv_mm = r.focal_mm * *crop;
    }
  }

  // Coverage of the imager by inlier corners, on a 16 x 10 grid.
  constexpr int kGx = 16, kGy = 10;
  std::vector<int> cells(kGx * kGy, 0);
  for (const auto& res : s.residuals) {
    if (res.outlier) continue;
    const auto& c = data.views[res.view].corners[res.corner];
    const int gx = std::clamp(static_cast<int>(c.x_px / data.imager_width_px * kGx), 0, kGx - 1);
    const int gy = std::clamp(static_cast<int>(c.y_px / data.imager_height_px * kGy), 0, kGy - 1);
    cells[gy * kGx + gx] = 1;
  }
  int covered = 0, edge = 0, edge_covered = 0;
  for (int gy = 0; gy < kGy; ++gy)
    for (int gx = 0; gx < kGx; ++gx) {
      covered += cells[gy * kGx + gx];
      if (gx == 0 || gy == 0 || gx == kGx - 1 || gy == kGy - 1) {
        ++edge;
        edge_covered += cells[gy * kGx + gx];
      }
    }
  r.coverage = double(covered) / (kGx * kGy);
  r.edge_coverage = double(edge_covered) / edge;

  // Tilt, two ways: off the line of sight to the board centre (foreshortening), and off
  // the image plane (the board normal against the optical axis). Boards parallel to the
  // image plane image by a similarity wherever they sit (x = f X / z + cx), so focal
  // length and distance trade off exactly; measured against the line of sight, such
  // boards off-axis read as tilted (20 deg on a 60-deg lens) and hid the degeneracy.
  std::vector<double> spans;
  r.tilt_min_deg = 180;
  r.tilt_max_deg = 0;
  r.tilt_plane_min_deg = 180;
  r.tilt_plane_max_deg = 0;
  const double diag = std::hypot(data.imager_width_px, data.imager_height_px);
  for (size_t i = 0; i < s.rt_cam_board.size(); ++i) {
    const auto& rt = s.rt_cam_board[i];
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
    const cv::Vec3d n(R(0, 2), R(1, 2), R(2, 2));
    const cv::Vec3d half(0.5 * (data.board.cols - 1) * data.board.spacing_m,
                         0.5 * (data.board.rows - 1) * data.board.spacing_m, 0);
    cv::Vec3d centre = R * half + cv::Vec3d(rt[3], rt[4], rt[5]);
    centre /= cv::norm(centre);
    const double tilt = std::acos(std::min(1.0, std::fabs(n.dot(centre)))) * kDeg;
    r.tilt_min_deg = std::min(r.tilt_min_deg, tilt);
    r.tilt_max_deg = std::max(r.tilt_max_deg, tilt);
    const double tilt_plane = std::acos(std::min(1.0, std::fabs(n[2]))) * kDeg;
    r.tilt_plane_min_deg = std::min(r.tilt_plane_min_deg, tilt_plane);
    r.tilt_plane_max_deg = std::max(r.tilt_plane_max_deg, tilt_plane);
    // Apparent size: the diagonal of the present corners' bounding box.
    double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
    for (const auto& c : data.views[s.views_used[i]].corners) {
      if (!c.present) continue;
      x0 = std::min(x0, c.x_px);
      x1 = std::max(x1, c.x_px);
      y0 = std::min(y0, c.y_px);
      y1 = std::max(y1, c.y_px);
    }
    spans.push_back(std::hypot(x1 - x0, y1 - y0) / diag);
  }
  if (!spans.empty()) {
    std::nth_element(spans.begin(), spans.begin() + spans.size() / 2, spans.end());
    r.board_span_median = spans[spans.size() / 2];
  }

  if (auto u = summarize_uncertainty(s); u.ok())
    r.uncertainty = std::move(*u);
  else
    r.uncertainty_error = u.error().message;

  const int used = static_cast<int>(s.views_used.size());
  if (used < 8)
    r.warnings.push_back(
        {"too_few_views", "only " + std::to_string(used) +
                              " views were solved; capture 15-30 views of the board "
                              "at varied positions, distances and tilts"});
  if (r.tilt_max_deg < 12 || r.tilt_plane_max_deg < 12)
    r.warnings.push_back(
        {"fronto_parallel",
         (r.tilt_plane_max_deg < 12
              ? "every board is within " + format_printf("%.1f", r.tilt_plane_max_deg) +
                    " deg of parallel to the image plane"
              : "every board faces the camera within " + format_printf("%.1f", r.tilt_max_deg) +
                    " deg") +
             ", so focal length and distance cannot be told apart; capture "
             "views with the board tilted 20-45 deg in different directions"});
  if (r.edge_coverage < 1.0 / 3)
    r.warnings.push_back(
        {"centre_only", "corners cover only " + format_printf("%.0f", 100 * r.edge_coverage) +
                            "% of the imager's border; distortion near the edges is extrapolated. "
                            "Capture views with the board reaching into the corners and edges"});
  if (r.board_span_median < 0.25)
    r.warnings.push_back(
        {"far_boards", "the boards span a median " +
                           format_printf("%.0f", 100 * r.board_span_median) +
                           "% of the imager diagonal; capture views closer to the camera so the "
                           "board fills a third or more of the image"});
  if (r.outlier_share > 0.05)
    r.warnings.push_back(
        {"many_outliers",
         format_printf("%.1f", 100 * r.outlier_share) +
             "% of the corners were rejected as outliers; check the board size and "
             "flatness, focus and motion blur, and recapture the worst views"});
  // Judged on the weighted residuals (mrcal's x = weight x residual: each corner in units
  // of the noise expected at its detection level). The plain RMS mixes in corners that
  // were found at coarse levels and are noisier by design (mrgingham's level 2: 4x), so
  // it passes 1 px on a lens the model describes exactly.
  if (r.rms_weighted_px > 1.0)
    r.warnings.push_back(
        {"high_residuals", "the residual RMS is " + format_printf("%.2f", r.rms_weighted_px) +
                               " px (each corner weighted by its detection level): the lens model "
                               "cannot describe this lens or the corners are poor; try a richer "
                               "model (OPENCV8, SPLINED_STEREOGRAPHIC)"});
  // Pixels are square to a fraction of a percent on every sensor we know, and the optical
  // axis meets the sensor inside it: intrinsics that say otherwise come from a wrong
  // board size, mislabelled corners or too little data, not from the lens.
  const auto& k = s.model.intrinsics;
  if (k.size() >= 4) {
    const double aspect = k[1] != 0 ? k[0] / k[1] : 0;
    const bool centre_inside =
        k[2] >= 0 && k[2] <= s.model.width_px - 1 && k[3] >= 0 && k[3] <= s.model.height_px - 1;
    if (!(aspect > 0.8 && aspect < 1.25) || !centre_inside)
      r.warnings.push_back(
          {"implausible_intrinsics",
           "fx/fy = " + format_printf("%.3g", aspect) + " and the principal point (" +
               format_printf("%.1f", k[2]) + ", " + format_printf("%.1f", k[3]) +
               ") px describe no ordinary camera (square pixels, axis inside "
               "the imager): check --board (inner corners), the spacing and the corners; "
               "an anamorphic lens is the one exception"});
  }
  if (!r.fov.all()) {
    // Name what is missing: a model that folds over only in the image corners still has
    // a horizontal and a vertical FOV, and they are reported.
    std::vector<std::string> missing;
    if (!r.fov.horizontal_deg) missing.push_back("horizontal");
    if (!r.fov.vertical_deg) missing.push_back("vertical");
    if (!r.fov.diagonal_deg) missing.push_back("diagonal");
    std::string which;
    for (size_t i = 0; i < missing.size(); ++i)
      which += (i == 0 ? "" : (i + 1 == missing.size() ? " and " : ", ")) + missing[i];
    const bool corners_only = missing.size() == 1 && missing[0] == "diagonal";
    r.warnings.push_back(
        {"fov_undefined", "the " + which + " FOV " + (missing.size() > 1 ? "are" : "is") +
                              " undefined: the fitted model does not invert at the image " +
                              (corners_only ? "corners" : "edges") +
                              (fov ? "" : " (" + fov.error().message + ")") +
                              " (it extrapolates beyond the boards)" +
                              (corners_only ? "; the horizontal and vertical FOV are given" : "") +
                              "; capture boards near the image " +
                              (corners_only ? "corners" : "edges") + " or use a simpler model"});
  }
  return r;
}

bool has_warning(const CalibrationReport& report, const std::string& code) {
  return std::any_of(report.warnings.begin(), report.warnings.end(),
                     [&](const Warning& w) { return w.code == code; });
}

nlohmann::json to_json(const CalibrationReport& r) {
  const auto& s = r.solution;
  nlohmann::json j;
  j["lensmodel"] = s.model.lensmodel;
  j["intrinsics"] = s.model.intrinsics;
  j["imagersize"] = {s.model.width_px, s.model.height_px};
  j["fx_px"] = s.model.intrinsics[0];
  j["fy_px"] = s.model.intrinsics[1];
  j["cx_px"] = s.model.intrinsics[2];
  j["cy_px"] = s.model.intrinsics[3];
  auto or_null = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json();
  };
  if (r.fov.any())
    j["fov_deg"] = {{"horizontal", or_null(r.fov.horizontal_deg)},
                    {"vertical", or_null(r.fov.vertical_deg)},
                    {"diagonal", or_null(r.fov.diagonal_deg)}};
  else
    j["fov_deg"] = nullptr;
  if (r.intrinsics_sigma) {
    const IntrinsicsUncertainty& u = *r.intrinsics_sigma;
    j["sigma_1"] = {{"fx_px", u.fx_px},
                    {"fy_px", u.fy_px},
                    {"cx_px", u.cx_px},
                    {"cy_px", u.cy_px},
                    {"fov_deg",
                     {{"horizontal", or_null(u.horizontal_fov_deg)},
                      {"vertical", or_null(u.vertical_fov_deg)},
                      {"diagonal", or_null(u.diagonal_fov_deg)}}},
                    {"source", "corner noise through the solve's covariance"}};
    if (r.pixel_pitch_um > 0)
      j["sigma_1"]["focal_mm"] = 0.5 * (u.fx_px + u.fy_px) * r.pixel_pitch_um / 1000;
  }
  if (r.pixel_pitch_um > 0) {
    j["pixel_pitch_um"] = r.pixel_pitch_um;
    j["focal_mm"] = r.focal_mm;
    j["crop_factor"] = r.crop_factor;
    j["focal_35mm_equiv_mm"] = r.focal_35mm_equiv_mm;
  }
  j["residuals"] = {{"rms_px", s.rms_px},
                    {"rms_weighted_px", r.rms_weighted_px},
                    {"worst_px", s.worst_px},
                    {"inliers", s.inliers}};
  j["outliers"] = {{"count", s.outliers}, {"share", r.outlier_share}};
  j["views"] = {{"total", r.views_total}, {"used", s.views_used.size()}};
  j["coverage"] = {{"imager", r.coverage}, {"border", r.edge_coverage}};
  j["tilt_deg"] = {{"min", r.tilt_min_deg}, {"max", r.tilt_max_deg}};
  j["tilt_image_plane_deg"] = {{"min", r.tilt_plane_min_deg}, {"max", r.tilt_plane_max_deg}};
  j["board_span_median"] = r.board_span_median;
  j["calobject_warp_m"] = s.calobject_warp;
  j["seed"] = {{"focal_px", s.seed_focal_px}, {"projection", s.seed_projection}};
  j["solve_s"] = s.solve_s;
  nlohmann::json ev = nlohmann::json::array();
  for (const auto& e : r.evidence) {
    nlohmann::json row = {{"lensmodel", e.lensmodel}, {"params", e.params}, {"ok", e.ok}};
    if (e.ok) {
      row["rms_px"] = e.rms_px;
      row["heldout_px"] = e.heldout_px;
      row["solve_s"] = e.solve_s;
      row["cv_s"] = e.cv_s;
      if (!e.note.empty()) row["note"] = e.note;
    } else {
      if (!e.error.empty()) row["error"] = e.error;
      if (!e.note.empty()) row["note"] = e.note;
    }
    ev.push_back(row);
  }
  j["model_selection"] = ev;
  if (!r.cross_validation.empty()) j["cross_validation"] = r.cross_validation;
  if (r.spline_check.considered)
    j["spline_cross_check"] = {{"ran", r.spline_check.ran},
                               {"residual_pattern_score", r.spline_check.residual_pattern_score},
                               {"reason", r.spline_check.reason}};
  if (r.uncertainty) {
    nlohmann::json pts = nlohmann::json::array();
    auto opt = [](const std::optional<double>& v) {
      return v ? nlohmann::json(*v) : nlohmann::json();
    };
    for (const auto& p : r.uncertainty->points)
      pts.push_back({{"where", p.where},
                     {"x_px", p.x_px},
                     {"y_px", p.y_px},
                     {"at_infinity_px", opt(p.at_infinity_px)},
                     {"at_working_distance_px", opt(p.at_working_distance_px)}});
    j["projection_uncertainty"] = {
        {"method",
         "mrcal mean-frames: observation noise through J to intrinsics and board poses; "
         "worst-direction 1-sigma"},
        {"observed_sigma_px", r.uncertainty->observed_sigma_px},
        {"working_distance_m", r.uncertainty->working_distance_m},
        {"points", pts}};
  } else {
    j["projection_uncertainty"] = {{"error", r.uncertainty_error}};
  }
  if (r.repeatability)
    j["repeatability"] = to_json(*r.repeatability);
  else if (!r.repeatability_error.empty())
    j["repeatability"] = {{"error", r.repeatability_error}};
  nlohmann::json w = nlohmann::json::array();
  for (const auto& x : r.warnings) w.push_back({{"code", x.code}, {"message", x.message}});
  j["warnings"] = w;
  return j;
}

std::string to_text(const CalibrationReport& r) {
  const auto& s = r.solution;
  std::string t;
  char buf[768];
  if (!r.evidence.empty()) {
    t += r.cross_validation == "corners"
             ? "model selection (held-out: every third corner left out of the fit; fewer than 6 "
               "views):\n"
             : "model selection (held-out: views left out of the fit, poses refitted):\n";
    t += "  model                      params   rms_px  heldout_px  solve_s     cv_s\n";
    for (const auto& e : r.evidence) {
      if (e.ok)
        std::snprintf(buf, sizeof buf, "  %-26s %6d %8.4f %11.4f %8.3f %8.3f%s\n",
                      e.lensmodel.c_str(), e.params, e.rms_px, e.heldout_px, e.solve_s, e.cv_s,
                      e.lensmodel == s.model.lensmodel ? "  <- chosen" : "");
      else if (!e.note.empty())
        std::snprintf(buf, sizeof buf, "  %-26s %6d %8.4f  %s%s\n", e.lensmodel.c_str(), e.params,
                      e.rms_px, e.note.c_str(),
                      e.lensmodel == s.model.lensmodel ? "  <- chosen" : "");
      else
        std::snprintf(buf, sizeof buf, "  %-26s %6d  failed: %s\n", e.lensmodel.c_str(), e.params,
                      e.error.c_str());
      t += buf;
    }
  }
  if (r.spline_check.considered) t += "  spline cross-check " + r.spline_check.reason + "\n";
  t += "lensmodel: " + s.model.lensmodel + "\n";
  // "537.131 +- 0.812": a value and its 1-sigma where the covariance gives one.
  auto with_sigma = [](double v, std::optional<double> sigma) {
    return sigma ? format_printf("%.3f +- %.3f", v, *sigma) : format_printf("%.3f", v);
  };
  const std::optional<IntrinsicsUncertainty>& u = r.intrinsics_sigma;
  t += "fx " + with_sigma(s.model.intrinsics[0], u ? std::optional(u->fx_px) : std::nullopt) +
       " px  fy " + with_sigma(s.model.intrinsics[1], u ? std::optional(u->fy_px) : std::nullopt) +
       " px  cx " + with_sigma(s.model.intrinsics[2], u ? std::optional(u->cx_px) : std::nullopt) +
       " px  cy " + with_sigma(s.model.intrinsics[3], u ? std::optional(u->cy_px) : std::nullopt) +
       " px" + (u ? " (1 sigma from corner noise)" : "") + "\n";
  if (r.fov.any()) {
    auto deg = [&](const std::optional<double>& v, std::optional<double> sigma) {
      return v ? with_sigma(*v, sigma) : std::string("undefined");
    };
    t += "FOV (unprojected image edges): " +
         deg(r.fov.horizontal_deg, u ? u->horizontal_fov_deg : std::nullopt) + " x " +
         deg(r.fov.vertical_deg, u ? u->vertical_fov_deg : std::nullopt) + " deg, diagonal " +
         deg(r.fov.diagonal_deg, u ? u->diagonal_fov_deg : std::nullopt) +
         (r.fov.diagonal_deg ? " deg" : "") + "\n";
  }
  if (r.pixel_pitch_um > 0) {
    const std::string sigma_mm =
        u ? format_printf(" +- %.4f", 0.5 * (u->fx_px + u->fy_px) * r.pixel_pitch_um / 1000) : "";
    std::snprintf(buf, sizeof buf,
                  "focal length %.4f%s mm (pixel %.3f um), 35-mm equivalent %.2f mm (crop %.3f)\n",
                  r.focal_mm, sigma_mm.c_str(), r.pixel_pitch_um, r.focal_35mm_equiv_mm,
                  r.crop_factor);
    t += buf;
  }
  std::snprintf(buf, sizeof buf,
                "residuals: rms %.4f px, worst %.3f px over %d corners; outliers %d (%.2f%%)\n",
                s.rms_px, s.worst_px, s.inliers, s.outliers, 100 * r.outlier_share);
  t += buf;
  std::snprintf(
      buf, sizeof buf,
      "views %zu of %d; coverage %.0f%% of the imager, %.0f%% of its border; tilt %.1f-%.1f deg\n",
      s.views_used.size(), r.views_total, 100 * r.coverage, 100 * r.edge_coverage, r.tilt_min_deg,
      r.tilt_max_deg);
  t += buf;
  if (r.uncertainty) {
    std::snprintf(buf, sizeof buf,
                  "projection uncertainty (1 sigma, worst direction; corner noise %.3f px), px at "
                  "infinity / at %.3g m:\n",
                  r.uncertainty->observed_sigma_px, r.uncertainty->working_distance_m);
    t += buf;
    auto v = [](const std::optional<double>& x) {
      return x ? format_printf("%.4f", *x) : std::string("n/a");
    };
    for (const auto& p : r.uncertainty->points) {
      std::snprintf(buf, sizeof buf, "  %-13s (%7.1f, %7.1f)  %s / %s\n", p.where.c_str(), p.x_px,
                    p.y_px, v(p.at_infinity_px).c_str(), v(p.at_working_distance_px).c_str());
      t += buf;
    }
  } else if (!r.uncertainty_error.empty()) {
    t += "projection uncertainty: " + r.uncertainty_error + "\n";
  }
  if (r.repeatability)
    t += to_text(*r.repeatability);
  else if (!r.repeatability_error.empty())
    t += "repeatability: " + r.repeatability_error + "\n";
  for (const auto& w : r.warnings) t += "warning [" + w.code + "]: " + w.message + "\n";
  return t;
}

}  // namespace camlab::calib
