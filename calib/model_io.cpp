#include "calib/model_io.h"

#include <opencv2/core.hpp>

#include "image/cameramodel_file.h"

namespace camlab::calib {

std::string cameramodel_text(const LensModel& model, const std::string& comment) {
  image::CameraModelText t;
  t.lensmodel = model.lensmodel;
  t.intrinsics = model.intrinsics;
  t.rt_cam_ref = {0, 0, 0, 0, 0, 0};
  t.imagersize = {static_cast<unsigned>(model.width_px), static_cast<unsigned>(model.height_px)};
  t.comment = comment;
  return image::to_cameramodel_text(t);
}

bool has_opencv_equivalent(const LensModel& model) {
  return model.lensmodel == "LENSMODEL_PINHOLE" || model.lensmodel == "LENSMODEL_OPENCV4" ||
         model.lensmodel == "LENSMODEL_OPENCV5" || model.lensmodel == "LENSMODEL_OPENCV8" ||
         model.lensmodel == "LENSMODEL_OPENCV12";
}

Result<std::string> opencv_yaml_text(const LensModel& model) {
  if (!has_opencv_equivalent(model) || model.intrinsics.size() < 4)
    return make_error("no_opencv_equivalent",
                      model.lensmodel + " has no OpenCV equivalent; use the .cameramodel");
  const auto& in = model.intrinsics;
  cv::Mat K = (cv::Mat_<double>(3, 3) << in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1);
  // PINHOLE: OpenCV's minimum of 4 zero coefficients.
  std::vector<double> d(in.begin() + 4, in.end());
  if (d.empty()) d.assign(4, 0.0);
  cv::Mat D(1, static_cast<int>(d.size()), CV_64F, d.data());
  cv::FileStorage fs("calibration.yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "image_width" << model.width_px;
  fs << "image_height" << model.height_px;
  fs << "camera_matrix" << K;
  fs << "distortion_coefficients" << D;
  fs << "mrcal_lensmodel" << model.lensmodel;
  return fs.releaseAndGetString();
}

}  // namespace camlab::calib
