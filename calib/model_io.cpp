#include "calib/model_io.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/npz_writer.h"
#include "calib/uncertainty.h"
#include "image/cameramodel_file.h"

namespace camlab::calib {

namespace {

image::CameraModelText model_text(const LensModel& model, const std::string& comment,
                                  const std::array<double, 6>& rt_cam_ref = {}) {
  image::CameraModelText t;
  t.lensmodel = model.lensmodel;
  t.intrinsics = model.intrinsics;
  t.rt_cam_ref = rt_cam_ref;
  t.imagersize = {static_cast<unsigned>(model.width_px), static_cast<unsigned>(model.height_px)};
  t.comment = comment;
  return t;
}

// The weights of the final problem's observations (used view x corner, row-major) from
// the solution alone, as solver.cpp's solve() leaves its pool: make_mrcal_problem's
// weights (-1 for missing corners), x 1e-3 in the views it keeps down-weighted, mrcal's
// outlier mark (-1) on the corners it rejected. Solution flags every corner of a
// down-weighted view as an outlier, so inside those views mrcal's own rejections are not
// visible; with a weight of 1e-3 their measurements are too small to be rejected anyway.
std::vector<double> pool_weights_from_solution(const Solution& s, const CalibrationData& data) {
  const size_t per_view = static_cast<size_t>(data.board.cols) * data.board.rows;
  std::vector<double> w(s.views_used.size() * per_view, -1.0);
  for (size_t i = 0; i < s.views_used.size(); ++i) {
    const bool down = i < s.view_downweighted.size() && s.view_downweighted[i];
    const auto& corners = data.views[s.views_used[i]].corners;
    for (size_t k = 0; k < per_view; ++k)
      if (corners[k].present)
        w[i * per_view + k] = down ? corners[k].weight * 1e-3 : corners[k].weight;
  }
  for (const auto& r : s.residuals) {
    const auto it = std::find(s.views_used.begin(), s.views_used.end(), r.view);
    const size_t i = it - s.views_used.begin();
    const bool down = i < s.view_downweighted.size() && s.view_downweighted[i];
    if (r.outlier && !down) w[i * per_view + r.corner] = -1.0;
  }
  return w;
}

// The nested-list JSON array `j` as a flat row-major vector and its shape. Error when the
// nesting is ragged or a leaf is not a number.
template <typename T>
Result<std::vector<T>> flatten(const nlohmann::json& j, std::vector<size_t>* shape) {
  shape->clear();
  for (const nlohmann::json* p = &j; p->is_array(); p = &(*p)[0]) {
    shape->push_back(p->size());
    if (p->empty()) break;
  }
  std::vector<T> out;
  bool ok = true;
  auto walk = [&](auto&& self, const nlohmann::json& node, size_t depth) -> void {
    if (depth == shape->size()) {
      if (!node.is_number())
        ok = false;
      else
        out.push_back(node.get<T>());
      return;
    }
    if (!node.is_array() || node.size() != (*shape)[depth]) {
      ok = false;
      return;
    }
    for (const auto& c : node) self(self, c, depth + 1);
  };
  walk(walk, j, 0);
  if (!ok) return make_error("internal", "a ragged array in the optimization inputs");
  return out;
}

// mrcal_optimization_inputs' JSON as the .npz mrcal-calibrate-cameras would have written,
// in its key order.
Result<std::string> inputs_npz(const nlohmann::json& in,
                               const std::vector<std::string>& imagepaths) {
  NpzWriter npz;
  std::vector<size_t> shape;
  auto f64 = [&](const char* key) -> Status {
    std::vector<double> v;
    CAMLAB_ASSIGN(v, flatten<double>(in.at(key), &shape));
    npz.add_float64(key, v, shape);
    return {};
  };
  auto i32 = [&](const char* key) -> Status {
    std::vector<int32_t> v;
    CAMLAB_ASSIGN(v, flatten<int32_t>(in.at(key), &shape));
    npz.add_int32(key, v, shape);
    return {};
  };
  auto none = [&](const char* key) { npz.add_string(key, ""); };  // mrcal's None
  auto flag = [&](const char* key) { npz.add_bool(key, in.at(key).get<bool>()); };
  if (Status st = f64("intrinsics"); !st) return st.error();
  npz.add_float64("extrinsics_rt_fromref", {}, {0, 6});  // camera 0 is the reference
  if (Status st = f64("frames_rt_toref"); !st) return st.error();
  none("points");
  if (Status st = f64("observations_board"); !st) return st.error();
  if (Status st = i32("indices_frame_camintrinsics_camextrinsics"); !st) return st.error();
  none("observations_point");
  none("indices_point_camintrinsics_camextrinsics");
  npz.add_string("lensmodel", in.at("lensmodel").get<std::string>());
  if (Status st = i32("imagersizes"); !st) return st.error();
  if (Status st = f64("calobject_warp"); !st) return st.error();
  for (const char* key :
       {"do_optimize_intrinsics_core", "do_optimize_intrinsics_distortions",
        "do_optimize_extrinsics", "do_optimize_frames", "do_optimize_calobject_warp"})
    flag(key);
  npz.add_float64("calibration_object_spacing", in.at("calibration_object_spacing").get<double>());
  flag("do_apply_outlier_rejection");
  flag("do_apply_regularization");
  npz.add_bool("verbose", false);
  npz.add_strings("imagepaths", imagepaths);
  return npz.archive();
}

}  // namespace

std::string cameramodel_text(const LensModel& model, const std::string& comment,
                             const std::array<double, 6>& rt_cam_ref) {
  return image::to_cameramodel_text(model_text(model, comment, rt_cam_ref));
}

Result<std::string> cameramodel_text_with_inputs(const Solution& solution,
                                                 const CalibrationData& data,
                                                 const std::string& comment) {
  const size_t per_view = static_cast<size_t>(data.board.cols) * data.board.rows;
  if (solution.views_used.empty() || solution.rt_cam_board.size() != solution.views_used.size())
    return make_error("invalid_argument", "the solution has no solved views");
  std::vector<std::string> imagepaths;
  for (int v : solution.views_used) {
    if (v < 0 || v >= static_cast<int>(data.views.size()) ||
        data.views[v].corners.size() != per_view)
      return make_error("invalid_argument", "the calibration data are not those of the solution");
    imagepaths.push_back(data.views[v].name);
  }
  for (const auto& r : solution.residuals)
    if (r.corner < 0 || static_cast<size_t>(r.corner) >= per_view ||
        std::find(solution.views_used.begin(), solution.views_used.end(), r.view) ==
            solution.views_used.end())
      return make_error("invalid_argument", "a residual of the solution names no solved corner");

  // Without a kept state, a stand-in holding only what the export reads: the weights
  // and the stage selections of solve()'s last stage (core always; distortions and
  // regularization with a distortion model; the warp when it was solved, i.e. non-zero).
  Solution s = solution;
  if (!s.covariance) {
    auto problem = std::make_shared<StateCovariance>();
    problem->pool_weight = pool_weights_from_solution(s, data);
    problem->optimized_core = true;
    problem->optimized_distortions = problem->regularized = s.model.intrinsics.size() > 4;
    problem->optimized_warp = s.calobject_warp[0] != 0 || s.calobject_warp[1] != 0;
    s.covariance = std::move(problem);
  }
  nlohmann::json inputs;
  CAMLAB_ASSIGN(inputs, mrcal_optimization_inputs(data, s));
  std::string npz;
  try {  // .at()/.get() throw only if uncertainty.cpp's export changes shape: a bug
    CAMLAB_ASSIGN(npz, inputs_npz(inputs, imagepaths));
  } catch (const nlohmann::json::exception& e) {
    return make_error("internal", std::string("unexpected optimization inputs: ") + e.what());
  }
  image::CameraModelText t = model_text(solution.model, comment);
  t.optimization_inputs_b85 = base85_encode(npz);
  t.icam_intrinsics = 0;
  return image::to_cameramodel_text(t);
}

bool has_opencv_equivalent(const LensModel& model) {
  return model.lensmodel == "LENSMODEL_PINHOLE" || model.lensmodel == "LENSMODEL_OPENCV4" ||
         model.lensmodel == "LENSMODEL_OPENCV5" || model.lensmodel == "LENSMODEL_OPENCV8" ||
         model.lensmodel == "LENSMODEL_OPENCV12";
}

Result<std::string> opencv_yaml_text(const LensModel& model) {
  if (!has_opencv_equivalent(model) || model.intrinsics.size() < 4)
    return make_error("unsupported",
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
