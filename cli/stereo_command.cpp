// `camlab stereo rectify|triangulate`: the products of a calibrated rig (the folder
// `camlab calibrate --rig --out` writes): a pair's images rectified, and points matched in
// two cameras triangulated with their uncertainty.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "base/format.h"
#include "calib/rig/rectification.h"
#include "calib/rig/rig_folder.h"
#include "calib/rig/rig_range.h"
#include "calib/rig/stereo_images.h"
#include "command_errors.h"
#include "commands.h"

namespace camlab::cli {
namespace {

struct StereoArgs {
  std::string rig_dir;
  int camera = 1;
  bool json = false;
  // rectify
  std::string image0, image_other, out;
  double az_fov_deg = 0, el_fov_deg = 0;
  std::string rectification = "auto";
  // triangulate
  std::vector<double> pixels;
  std::string matches_path;
  double pixel_sigma_px = -1;
};

// A matches file: one point a line, "x0 y0 xN yN" (px), '#' starts a comment; appended to
// `pixels`. Errors name the line.
void read_matches(const std::string& path, std::vector<double>* pixels,
                  const CommandErrors& errors) {
  std::ifstream in(path);
  if (!in) errors.fail("io_error", "cannot read " + path);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    std::istringstream fields(line);
    std::vector<double> values;
    for (double v; fields >> v;) values.push_back(v);
    const bool all_read = fields.eof();
    if (values.empty() && all_read) continue;
    if (!all_read || values.size() != 4)
      errors.fail("invalid_argument", format_printf("%s:%d: a match is 4 numbers, x0 y0 xN yN (px)",
                                                    path.c_str(), number));
    pixels->insert(pixels->end(), values.begin(), values.end());
  }
}

calib::RigSolution load_rig(const StereoArgs& args, const CommandErrors& errors) {
  calib::RigSolution rig = errors.take(calib::read_rig_folder(args.rig_dir));
  const int n = static_cast<int>(rig.cameras.size());
  if (args.camera < 1 || args.camera >= n)
    errors.fail("out_of_range", format_printf("--camera %d: this rig's other cameras are 1..%d",
                                              args.camera, n - 1));
  return rig;
}

void run_rectify(const StereoArgs& args) {
  const CommandErrors errors("camlab stereo rectify", args.json);
  const calib::RigSolution rig = load_rig(args, errors);
  const bool latlon =
      args.rectification == "latlon" ||
      (args.rectification == "auto" &&
       calib::suited_rectified_model(rig.cameras[0].model, args.az_fov_deg, args.el_fov_deg) ==
           calib::RectifiedModel::kLatlon);
  const calib::StereoRectification r = errors.take(calib::rectify_pair(
      rig, args.camera, args.az_fov_deg, args.el_fov_deg,
      latlon ? calib::RectifiedModel::kLatlon : calib::RectifiedModel::kPinhole));
  const nlohmann::json out =
      errors.take(calib::rectify_image_files(r, rig, args.image0, args.image_other, args.out));
  if (args.json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "rectified camera 0 and camera %d (%s): %dx%d px, focal %.2f px%s, baseline %.2f mm\n",
      args.camera, latlon ? "lat-lon" : "pinhole", r.rectified.width_px, r.rectified.height_px,
      r.rectified.intrinsics[0], latlon ? " a radian" : "", r.baseline_m * 1000);
  std::printf("%s\n", out["range_rule"].get<std::string>().c_str());
  for (const auto& f : out["files"]) std::printf("wrote %s\n", f.get<std::string>().c_str());
}

void run_triangulate(const StereoArgs& args) {
  const CommandErrors errors("camlab stereo triangulate", args.json);
  std::vector<double> pixels = args.pixels;
  if (!args.matches_path.empty()) read_matches(args.matches_path, &pixels, errors);
  if (pixels.empty() || pixels.size() % 4 != 0)
    errors.fail("invalid_argument",
                format_printf("give matches with --pixels x0,y0,x%d,y%d per point (px; camera 0's "
                              "pixel, then camera %d's) or --matches FILE; %zu numbers given",
                              args.camera, args.camera, args.camera, pixels.size()));
  const calib::RigSolution rig = load_rig(args, errors);
  // The pixels' noise: given, else the corner noise the calibration showed.
  double sigma_px = args.pixel_sigma_px;
  std::string sigma_source = "--pixel-sigma";
  if (sigma_px < 0) {
    if (!(rig.corner_sigma_px > 0))
      errors.fail("invalid_argument",
                  "the rig folder has no rig.json with the corner noise: give --pixel-sigma PX");
    sigma_px = rig.corner_sigma_px;
    sigma_source = "the calibration's corner noise";
  }
  nlohmann::json points = nlohmann::json::array();
  for (size_t i = 0; i < pixels.size(); i += 4) {
    const std::array<double, 2> q0{pixels[i], pixels[i + 1]};
    const std::array<double, 2> q1{pixels[i + 2], pixels[i + 3]};
    auto p = calib::triangulate_point(rig, args.camera, q0, q1, sigma_px);
    if (!p) errors.fail(p.error().with_context(format_printf("point %zu: ", i / 4)));
    nlohmann::json j = {{"pixel_camera0", q0},
                        {"pixel_other", q1},
                        {"point_m", p->point_m},
                        {"point_sigma_mm", p->point_sigma_mm},
                        {"range_m", p->range_m},
                        {"range_sigma_mm", p->range_sigma_mm},
                        {"range_sigma_pixels_mm", p->range_sigma_pixels_mm},
                        {"miss_mm", p->miss_mm}};
    j["range_sigma_calibration_mm"] = p->range_sigma_calibration_mm >= 0
                                          ? nlohmann::json(p->range_sigma_calibration_mm)
                                          : nlohmann::json(nullptr);
    points.push_back(std::move(j));
  }
  const bool calibration_part =
      !points.empty() && !points[0]["range_sigma_calibration_mm"].is_null();
  if (args.json) {
    std::printf("%s\n", nlohmann::json{{"camera", args.camera},
                                       {"frame", "camera 0 (x right, y down, z forward; m)"},
                                       {"pixel_sigma_px", sigma_px},
                                       {"pixel_sigma_source", sigma_source},
                                       {"calibration_uncertainty", calibration_part},
                                       {"points", points}}
                            .dump(2)
                            .c_str());
    return;
  }
  std::printf("camera 0 and camera %d; point in camera 0's frame (m); pixel noise %.3f px (%s)\n",
              args.camera, sigma_px, sigma_source.c_str());
  for (const auto& j : points) {
    const auto p = j["point_m"].get<std::array<double, 3>>();
    std::printf("(%.2f, %.2f) + (%.2f, %.2f): (%.4f, %.4f, %.4f) m, range %.4f m +- %.2f mm",
                j["pixel_camera0"][0].get<double>(), j["pixel_camera0"][1].get<double>(),
                j["pixel_other"][0].get<double>(), j["pixel_other"][1].get<double>(), p[0], p[1],
                p[2], j["range_m"].get<double>(), j["range_sigma_mm"].get<double>());
    std::printf(" (pixels %.2f", j["range_sigma_pixels_mm"].get<double>());
    if (!j["range_sigma_calibration_mm"].is_null())
      std::printf(", calibration %.2f", j["range_sigma_calibration_mm"].get<double>());
    std::printf(" mm), rays %.2f mm apart\n", j["miss_mm"].get<double>());
  }
  if (!calibration_part)
    std::printf(
        "warning: the calibration's own uncertainty is left out: rig.json carries no parameter "
        "covariance (rigs of more than %d parameters, or no rig.json)\n",
        calib::kRigCovarianceStoredMax);
}

}  // namespace

void register_stereo_command(CLI::App& app) {
  auto args = std::make_shared<StereoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "stereo",
      "a calibrated rig's stereo products: a pair's images rectified (a point on one row in\n"
      "both), points matched in two cameras triangulated with their uncertainty. RIG is the\n"
      "folder camlab calibrate --rig --out wrote (camera-N.cameramodel, rig.json)");
  cmd->require_subcommand(1);
  const auto add_common = [&](CLI::App* sub) {
    sub->add_option("--rig", args->rig_dir, "rig folder (camera-N.cameramodel, rig.json)")
        ->required()
        ->check(CLI::ExistingDirectory);
    sub->add_option("--camera", args->camera, "the pair's other camera (camera 0 is the first)")
        ->check(CLI::Range(1, 7));
    sub->add_flag("--json", args->json, "print the result as JSON");
  };
  CLI::App* rectify = cmd->add_subcommand(
      "rectify",
      "rectify camera 0's and camera N's images: both turned to the baseline, one model for\n"
      "both (mrcal-stereo's rectification: LENSMODEL_PINHOLE, or LENSMODEL_LATLON, even in\n"
      "angle, for wide and fisheye pairs); writes rectified-0.png and rectified-N.png at the\n"
      "input's bit depth, and prints how to turn a match's columns into a range");
  add_common(rectify);
  rectify->add_option("IMAGE0", args->image0, "camera 0's image")
      ->required()
      ->check(CLI::ExistingFile);
  rectify->add_option("IMAGE_N", args->image_other, "camera N's image of the same moment")
      ->required()
      ->check(CLI::ExistingFile);
  rectify->add_option("--out", args->out, "output folder")->required();
  rectify
      ->add_option("--az-fov-deg", args->az_fov_deg,
                   "rectified field along the baseline (deg; default camera 0's, at most 150 "
                   "for a pinhole, 180 for lat-lon; a pinhole spans under 170)")
      ->check(CLI::Range(0.0, 180.0));
  rectify
      ->add_option("--el-fov-deg", args->el_fov_deg,
                   "rectified field across the baseline (deg; default camera 0's)")
      ->check(CLI::Range(0.0, 180.0));
  rectify
      ->add_option("--rectification", args->rectification,
                   "pinhole (straight lines stay straight; the image grows as tan of the half "
                   "field), latlon (rows are epipolar planes' angles, columns angles within "
                   "them: a 180-deg fisheye pair fits), or auto (latlon past 120 deg of field, "
                   "asked for or camera 0's; default)")
      ->check(CLI::IsMember({"auto", "pinhole", "latlon"}));
  rectify->callback([args] { run_rectify(*args); });

  CLI::App* triangulate = cmd->add_subcommand(
      "triangulate",
      "triangulate points matched in camera 0 and camera N (the rays' midpoint), each with\n"
      "its range's 1-sigma from the pixels' noise and the calibration's covariance");
  add_common(triangulate);
  triangulate
      ->add_option("--pixels", args->pixels,
                   "x0,y0,xN,yN per point (px), repeatable: camera 0's pixel, then camera N's")
      ->delimiter(',');
  triangulate
      ->add_option("--matches", args->matches_path,
                   "a file of matches, one a line: x0 y0 xN yN (px); '#' comments")
      ->check(CLI::ExistingFile);
  triangulate
      ->add_option("--pixel-sigma", args->pixel_sigma_px,
                   "the matched pixels' noise per coordinate (px); default: the calibration's "
                   "corner noise from rig.json")
      ->check(CLI::Range(0.0, 100.0));
  triangulate->callback([args] { run_triangulate(*args); });
}

}  // namespace camlab::cli
