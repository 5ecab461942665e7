#include "calib/rig/stereo_images.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/format.h"

namespace camlab::calib {

namespace fs = std::filesystem;

Result<nlohmann::json> rectify_image_files(const StereoRectification& r, const RigSolution& rig,
                                           const fs::path& image0, const fs::path& image_other,
                                           const fs::path& out_dir) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return make_error("io_error", "cannot create " + out_dir.string() + ": " + ec.message());
  nlohmann::json files = nlohmann::json::array();
  const int cameras[2] = {0, r.camera};
  const fs::path inputs[2] = {image0, image_other};
  for (int k = 0; k < 2; ++k) {
    const int c = cameras[k];
    const cv::Mat image = cv::imread(inputs[k].string(), cv::IMREAD_UNCHANGED);
    if (image.empty())
      return make_error("io_error", inputs[k].string() + ": not an image OpenCV can read");
    const LensModel& lens = rig.cameras[c].model;
    if (image.cols != lens.width_px || image.rows != lens.height_px)
      return make_error("imager_mismatch",
                        format_printf("%s is %dx%d; camera %d's imager is %dx%d", inputs[k].c_str(),
                                      image.cols, image.rows, c, lens.width_px, lens.height_px));
    std::array<cv::Mat, 2> maps;
    CAMLAB_ASSIGN(maps, rectification_maps(r, rig, c));
    cv::Mat rectified;
    cv::remap(image, rectified, maps[0], maps[1], cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    const fs::path out = out_dir / ("rectified-" + std::to_string(c) + ".png");
    if (!cv::imwrite(out.string(), rectified))
      return make_error("io_error", "cannot write " + out.string());
    files.push_back(out.string());
  }
  const double focal_px = r.rectified.intrinsics[0];
  const bool latlon = r.rectified.lensmodel == "LENSMODEL_LATLON";
  const std::string range_rule =
      latlon ? format_printf(
                   "columns are angles: az = (x - %.6g) / %.6g rad in each image; range from "
                   "camera 0 = %.6g m x cos(az_%d) / sin(az_0 - az_%d)",
                   r.rectified.intrinsics[2], focal_px, r.baseline_m, r.camera, r.camera)
             : format_printf(
                   "depth along the rectified axis z = %.6g m px / disparity px (disparity = "
                   "x in rectified-0 minus x in rectified-%d)",
                   focal_px * r.baseline_m, r.camera);
  return nlohmann::json{
      {"files", files},
      {"camera", r.camera},
      {"imager_px", {r.rectified.width_px, r.rectified.height_px}},
      {"focal_px", focal_px},
      {"principal_point_px", {r.rectified.intrinsics[2], r.rectified.intrinsics[3]}},
      {"baseline_m", r.baseline_m},
      {"rectification", r.rectified.lensmodel},
      {"range_rule", range_rule}};
}

}  // namespace camlab::calib
