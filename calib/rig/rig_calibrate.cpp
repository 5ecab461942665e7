#include "calib/rig/rig_calibrate.h"

#include <algorithm>
#include <fstream>
#include <map>
#include <set>

#include "base/atomic_file.h"
#include "base/cancel.h"
#include "base/format.h"
#include "calib/library_stderr.h"
#include "calib/model_io.h"
#include "calib/model_selection.h"
#include "calib/rig/rectification.h"
#include "calib/rig/rig_drift.h"
#include "calib/rig/rig_folder.h"
#include "calib/rig/rig_range.h"

namespace camlab::calib {

namespace {

namespace fs = std::filesystem;

// The view's key across cameras: its file name without the folder; for a pattern of file
// names (left*.jpg), the part its wildcards match (left01.jpg -> 01), as mrcal's tools
// match a rig's images.
std::string view_key(const BoardView& v, const fs::path& images) {
  const std::string name = fs::path(v.name).filename().string();
  if (images.empty() || !is_image_pattern(images)) return name;
  const std::string pattern = images.filename().string();
  const size_t first = pattern.find_first_of("*?["), last = pattern.find_last_of("*?]");
  const size_t prefix = first, suffix = pattern.size() - last - 1;
  if (name.size() < prefix + suffix) return name;
  return name.substr(prefix, name.size() - prefix - suffix);
}

// Every camera's views on the union of keys, in key order; a camera without a key gets a
// view with every corner missing. Error when a camera's keys meet no other camera's.
Status align_views(const std::vector<CalibrationRun>& runs,
                   const std::vector<CalibrateOptions>& sources,
                   const std::vector<std::map<std::string, std::string>>& view_of_frame,
                   RigCalibrationRun* out) {
  // A view's key in camera c; empty when an explicit pairing leaves the frame out.
  auto key_of = [&](size_t c, const BoardView& v) -> std::string {
    if (c >= view_of_frame.size()) return view_key(v, sources[c].images_dir);
    const auto it = view_of_frame[c].find(fs::path(v.name).filename().string());
    return it == view_of_frame[c].end() ? std::string() : it->second;
  };
  std::set<std::string> names;
  std::vector<std::set<std::string>> keys(runs.size());
  for (size_t c = 0; c < runs.size(); ++c)
    for (const auto& v : runs[c].data.views) {
      const std::string key = key_of(c, v);
      if (key.empty()) continue;
      names.insert(key);
      keys[c].insert(key);
    }
  for (size_t c = 0; c < runs.size(); ++c) {
    bool meets = false;
    for (size_t o = 0; o < runs.size() && !meets; ++o)
      if (o != c)
        for (const auto& k : keys[c]) meets = meets || keys[o].count(k);
    if (!meets)
      return make_error("too_few_views",
                        format_printf("camera %zu's boards share no view name with the other "
                                      "cameras': a rig view is the images of one file name in "
                                      "every camera's folder, or of one wildcard part "
                                      "(--images 'DIR/left*.jpg' --images 'DIR/right*.jpg')",
                                      c));
  }
  out->view_names.assign(names.begin(), names.end());
  for (size_t c = 0; c < runs.size(); ++c) {
    const auto& run = runs[c];
    CalibrationData d = run.data;
    std::map<std::string, const BoardView*> by_name;
    for (const auto& v : run.data.views)
      if (const std::string key = key_of(c, v); !key.empty()) by_name[key] = &v;
    d.views.clear();
    for (const auto& name : out->view_names) {
      if (auto it = by_name.find(name); it != by_name.end()) {
        d.views.push_back(*it->second);
        continue;
      }
      BoardView missing;
      missing.name = name;
      missing.corners.assign(static_cast<size_t>(d.board.cols) * d.board.rows, {});
      d.views.push_back(std::move(missing));
    }
    out->data.cameras.push_back(std::move(d));
  }
  return {};
}

// Each camera's lens model: the one given, for all; or with `auto` each camera's own
// selection (model_selection.h) on its own views, which the joint solve keeps
// (rig_joint_solve.h solves cameras of different models together).
Result<std::vector<std::string>> rig_models(const RigCalibrateOptions& options,
                                            RigCalibrationRun* run) {
  const size_t n = run->data.cameras.size();
  if (options.model != "auto") {
    const CalibrationData& first = run->data.cameras[0];
    std::string model;
    CAMLAB_ASSIGN(model, configured_lensmodel(options.model, first.imager_width_px,
                                              first.imager_height_px, 90));
    return std::vector<std::string>(n, model);
  }
  for (size_t c = 0; c < n; ++c) {
    if (Status go = check_not_cancelled(options.cancel, "rig calibration"); !go) return go.error();
    CalibrationData seen = run->data.cameras[c];
    std::erase_if(seen.views, [](const BoardView& v) { return v.present_count() == 0; });
    SolveOptions o;
    o.board_warp = options.board_warp;
    o.compute_covariance = false;
    o.cancel = options.cancel;
    auto selection = select_model(seen, o, default_candidate_models());
    if (!selection)
      return selection.error().with_context(format_printf("camera %zu, model selection: ", c));
    run->own_models.push_back(selection->chosen.model.lensmodel);
  }
  return run->own_models;
}

}  // namespace

namespace {

// A part of the report that could not be made: its error as camlabd and --json give errors.
nlohmann::json error_json(const Error& error) {
  return {{"code", name_of(error.code)}, {"message", error.message}};
}

}  // namespace

nlohmann::json rig_report_json(const RigCalibrationRun& run) {
  const RigSolution& s = run.solution;
  nlohmann::json cameras = nlohmann::json::array();
  for (size_t c = 0; c < s.cameras.size(); ++c) {
    const RigCamera& cam = s.cameras[c];
    nlohmann::json j = {
        {"camera", c},
        {"lensmodel", cam.model.lensmodel},
        {"intrinsics", cam.model.intrinsics},
        {"imager_px", {cam.model.width_px, cam.model.height_px}},
        {"rt_cam_ref", nlohmann::json(cam.rt_cam_ref)},
        {"baseline_m", cam.baseline_m},
        {"baseline_sigma_mm", cam.baseline_sigma_mm},
        {"rotation_sigma_deg", cam.rotation_sigma_deg},
        {"translation_sigma_mm", cam.translation_sigma_mm},
        {"rt_cam_ref_covariance", cam.rt_covariance},
        {"rms_px", cam.rms_px},
        {"single_camera_rms_px", cam.single_rms_px},
        {"views", cam.views},
        {"inliers", cam.inliers},
        {"outliers", cam.outliers},
    };
    if (c < run.own_models.size()) j["own_lensmodel"] = run.own_models[c];
    cameras.push_back(std::move(j));
  }
  nlohmann::json views = nlohmann::json::array();
  for (int v : s.views_used) views.push_back(run.view_names.at(v));
  // The whole covariance, for triangulations' uncertainty (rig_folder.h), where it is small.
  nlohmann::json covariance = nullptr;
  if (s.parameter_count > 0 && s.parameter_count <= kRigCovarianceStoredMax &&
      s.parameter_covariance.size() == static_cast<size_t>(s.parameter_count) * s.parameter_count)
    covariance = {{"parameters", s.parameter_count},
                  {"order",
                   "every camera's intrinsics (camera 0 first), then rt_cam_ref of cameras 1..N-1; "
                   "row-major"},
                  {"values", s.parameter_covariance}};
  return {
      {"cameras", cameras},
      {"reference",
       "camera 0: rt_cam_ref maps points from camera 0's frame to camera N's "
       "(rad, m); sigmas are 1-sigma from the corner noise"},
      {"rms_px", s.rms_px},
      {"corner_sigma_px", s.corner_sigma_px},
      {"views", views},
      {"board", {{"cols", s.board.cols}, {"rows", s.board.rows}, {"spacing_m", s.board.spacing_m}}},
      {"calobject_warp_m", s.calobject_warp},
      {"parameter_covariance", covariance},
      {"warnings", s.warnings},
      {"range_uncertainty", run.range_uncertainty},
      {"drift", run.drift},
      {"rectification", run.rectification},
      {"solve_s", s.solve_s},
      {"files", run.files}};
}

std::string rig_report_text(const RigCalibrationRun& run) {
  const RigSolution& s = run.solution;
  std::string text =
      format_printf("rig of %zu cameras, %zu views: RMS %.3f px, corner noise %.3f px\n",
                    s.cameras.size(), s.views_used.size(), s.rms_px, s.corner_sigma_px);
  for (size_t c = 0; c < s.cameras.size(); ++c) {
    const RigCamera& cam = s.cameras[c];
    text += format_printf("camera %zu: %s, %dx%d, fx %.2f px, %d views, RMS %.3f px", c,
                          cam.model.lensmodel.c_str(), cam.model.width_px, cam.model.height_px,
                          cam.model.intrinsics[0], cam.views, cam.rms_px);
    if (c > 0)
      text += format_printf(
          "; baseline %.2f +- %.3f mm; rotation sigma %.4f/%.4f/%.4f deg, translation sigma "
          "%.3f/%.3f/%.3f mm",
          cam.baseline_m * 1000, cam.baseline_sigma_mm, cam.rotation_sigma_deg[0],
          cam.rotation_sigma_deg[1], cam.rotation_sigma_deg[2], cam.translation_sigma_mm[0],
          cam.translation_sigma_mm[1], cam.translation_sigma_mm[2]);
    text += "\n";
  }
  for (const auto& r : run.range_uncertainty) {
    if (r.contains("error")) {
      text += format_printf("range with camera %d: %s\n", r["camera"].get<int>(),
                            r["error"]["message"].get<std::string>().c_str());
      continue;
    }
    text += format_printf(
        "range %.3f m on camera 0's axis, triangulated with camera %d: 1-sigma %.3f mm from "
        "the calibration (intrinsics alone %.3f, extrinsics alone %.3f: they are correlated)\n",
        r["range_m"].get<double>(), r["camera"].get<int>(), r["sigma_mm"].get<double>(),
        r["sigma_intrinsics_alone_mm"].get<double>(), r["sigma_extrinsics_alone_mm"].get<double>());
  }
  for (const auto& r : run.rectification)
    if (r.contains("epipolar") && r["epipolar"].contains("rms_px"))
      text += format_printf(
          "cameras 0 and %d rectified (pinhole %dx%d): epipolar residual of the board corners "
          "%.3f px RMS, worst %.3f px over %d corners\n",
          r["camera"].get<int>(), r["rectified_imager_px"][0].get<int>(),
          r["rectified_imager_px"][1].get<int>(), r["epipolar"]["rms_px"].get<double>(),
          r["epipolar"]["worst_px"].get<double>(), r["epipolar"]["corners"].get<int>());
  if (run.drift.is_object())
    for (const auto& d : run.drift["cameras"])
      text += format_printf(
          "camera %d since %s: %s (rotation %.4f deg, translation %.3f mm; chi-square %.1f, "
          "moved above %.2f)\n",
          d["camera"].get<int>(), run.drift["from"].get<std::string>().c_str(),
          d["verdict"].get<std::string>().c_str(), d["rotation_deg"].get<double>(),
          d["translation_mm"].get<double>(), d["chi_square"].get<double>(),
          d["threshold"].get<double>());
  for (const auto& w : s.warnings) text += "warning: " + w + "\n";
  return text;
}

Result<RigCalibrationRun> calibrate_rig(const RigCalibrateOptions& options) {
  const int n = static_cast<int>(options.cameras.size());
  if (n < kRigCamerasMin || n > kRigCamerasMax)
    return make_error("invalid_argument",
                      format_printf("a rig has %d to %d cameras (one source each), not %d",
                                    kRigCamerasMin, kRigCamerasMax, n));
  std::vector<CalibrationRun> runs;
  for (int c = 0; c < n; ++c) {
    auto run = read_board_views(options.cameras[c]);
    if (!run) return run.error().with_context(format_printf("camera %d: ", c));
    runs.push_back(std::move(*run));
  }
  RigCalibrationRun out;
  if (Status aligned = align_views(runs, options.cameras, options.view_of_frame, &out); !aligned)
    return aligned.error();
  const LibraryStderrCapture quiet_mrcal;
  RigSolveOptions solve_options;
  CAMLAB_ASSIGN(solve_options.lensmodels, rig_models(options, &out));
  solve_options.board_warp = options.board_warp;
  solve_options.cancel = options.cancel;
  CAMLAB_ASSIGN(out.solution, solve_rig(out.data, solve_options));
  out.data = turned_rig_data(out.data, out.solution);
  if (options.range_m > 0)
    for (int c = 1; c < n; ++c) {
      auto r = triangulated_range_uncertainty(out.solution, c, options.range_m);
      if (!r) {
        out.range_uncertainty.push_back({{"camera", c}, {"error", error_json(r.error())}});
        continue;
      }
      out.range_uncertainty.push_back({{"camera", c},
                                       {"range_m", r->range_m},
                                       {"sigma_mm", r->sigma_mm},
                                       {"sigma_intrinsics_alone_mm", r->sigma_intrinsics_alone_mm},
                                       {"sigma_extrinsics_alone_mm", r->sigma_extrinsics_alone_mm},
                                       {"pixel_camera0", r->pixel_camera0},
                                       {"pixel_camera", r->pixel_other}});
    }
  std::vector<StereoRectification> rectified;
  for (int c = 1; c < n; ++c) {
    auto r =
        rectify_pair(out.solution, c, 0, 0, suited_rectified_model(out.solution.cameras[0].model));
    if (!r) {
      out.rectification.push_back({{"camera", c}, {"error", error_json(r.error())}});
      continue;
    }
    nlohmann::json j = {{"camera", c},
                        {"rt_rect_ref", nlohmann::json(r->rt_rect_ref)},
                        {"baseline_m", r->baseline_m},
                        {"az0_deg", r->az0_deg},
                        {"rectified_lensmodel", r->rectified.lensmodel},
                        {"rectified_intrinsics", r->rectified.intrinsics},
                        {"rectified_imager_px", {r->rectified.width_px, r->rectified.height_px}}};
    if (auto e = epipolar_residual(*r, out.data, out.solution); e.ok())
      j["epipolar"] = {{"rms_px", e->rms_px},
                       {"worst_px", e->worst_px},
                       {"corners", e->corners},
                       {"views", e->views}};
    else
      j["epipolar"] = {{"error", e.error().message}};
    out.rectification.push_back(std::move(j));
    rectified.push_back(*r);
  }
  if (!options.drift_from.empty()) {
    std::ifstream in(options.drift_from);
    if (!in) return make_error("io_error", "cannot read " + options.drift_from.string());
    const nlohmann::json before = nlohmann::json::parse(in, nullptr, false);
    if (before.is_discarded())
      return make_error("bad_json", options.drift_from.string() + " is not JSON");
    CAMLAB_ASSIGN(out.drift, rig_drift(before, rig_report_json(out)));
    out.drift["from"] = options.drift_from.string();
  }
  if (!options.out_dir.empty()) {
    std::error_code ec;
    fs::create_directories(options.out_dir, ec);
    if (ec)
      return make_error("io_error",
                        "cannot create " + options.out_dir.string() + ": " + ec.message());
    for (int c = 0; c < n; ++c) {
      const RigCamera& cam = out.solution.cameras[c];
      const fs::path path = options.out_dir / format_printf("camera-%d.cameramodel", c);
      const std::string comment = format_printf(
          "camlab calibrate --rig: camera %d of %d, extrinsics relative to camera 0", c, n);
      if (Status s =
              write_file_atomically(path, cameramodel_text(cam.model, comment, cam.rt_cam_ref));
          !s)
        return s.error();
      out.files.push_back(path.string());
    }
    for (const auto& r : rectified) {
      for (int which : {0, r.camera}) {
        const fs::path path =
            options.out_dir / format_printf("rectified-%d-%d.cameramodel", r.camera, which);
        const std::string comment =
            format_printf("camlab calibrate --rig: camera %d of the pair 0-%d, rectified (%s)",
                          which, r.camera, r.rectified.lensmodel.c_str());
        if (Status s = write_file_atomically(
                path, cameramodel_text(r.rectified, comment,
                                       which == 0 ? r.rt_rect_ref : r.rt_rect_other_ref));
            !s)
          return s.error();
        out.files.push_back(path.string());
      }
    }
    const fs::path report = options.out_dir / "rig.json";
    out.files.push_back(report.string());
    if (Status s = write_file_atomically(report, rig_report_json(out).dump(2) + "\n"); !s)
      return s.error();
  }
  out.report = rig_report_json(out);
  return out;
}

}  // namespace camlab::calib
