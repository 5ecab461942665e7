#include "service/jobs/calibration_request.h"

#include "calib/corners/charuco_corners.h"
#include "calib/lens_model.h"

namespace camlab::service {

Result<nlohmann::json> normalised_calibration_fields(const nlohmann::json& body) {
  nlohmann::json normalised = nlohmann::json::object();
  const nlohmann::json& corners = body.value("inner_corners", nlohmann::json());
  if (!corners.is_array() || corners.size() != 2 || !corners[0].is_number_integer() ||
      !corners[1].is_number_integer())
    return make_error("invalid_request", "\"inner_corners\" must be [COLS, ROWS], e.g. [14, 10]");
  const int cols = corners[0].get<int>(), rows = corners[1].get<int>();
  if (cols < 2 || rows < 2 || cols > 100 || rows > 100)
    return make_error("out_of_range", "inner corners must be in [2, 100] each");
  const nlohmann::json& spacing = body.value("spacing_m", nlohmann::json());
  if (!spacing.is_number())
    return make_error("invalid_request", "\"spacing_m\" (corner spacing in metres) is required");
  if (!(spacing.get<double>() > 0) || spacing.get<double>() > 10)
    return make_error("out_of_range", "spacing_m must be in (0, 10] metres");
  const nlohmann::json& model = body.value("model", nlohmann::json("auto"));
  if (!model.is_string() ||
      !(model == "auto" || model.get<std::string>().rfind("LENSMODEL_", 0) == 0) ||
      model.get<std::string>().size() > 200)
    return make_error("invalid_request",
                      "\"model\" must be \"auto\" or a mrcal LENSMODEL_... name");
  // A name mrcal does not know is refused now, not when the job reaches the solve. The
  // imager size only configures a bare splined model; any size checks the name.
  if (model != "auto") {
    std::string configured;
    CAMLAB_ASSIGN(configured, calib::configured_lensmodel(model.get<std::string>(), 1280, 800, 90));
    if (auto params = calib::lensmodel_param_count(configured); !params) return params.error();
  }
  const nlohmann::json& detector = body.value("detector", nlohmann::json("auto"));
  if (!detector.is_string() ||
      !(detector == "auto" || detector == "saddle" || detector == "opencv" ||
        detector == "mrgingham" || detector == "charuco" || detector == "markers"))
    return make_error(
        "invalid_request",
        "\"detector\" must be \"auto\" (camlab's saddle-point detector, with mrgingham on "
        "square boards where it misses), \"saddle\", \"opencv\", \"mrgingham\", \"markers\" "
        "(a chessboard with OpenCV's three circle markers: boards cut by the frame are kept) or "
        "\"charuco\" (a ChArUco board: give marker_m and dictionary too)");
  if (detector == "mrgingham" && cols != rows)
    return make_error("unsupported",
                      "the mrgingham detector finds square boards only (N x N inner corners)");
  if (detector == "charuco") {
    const nlohmann::json& marker = body.value("marker_m", nlohmann::json());
    const nlohmann::json& dictionary = body.value("dictionary", nlohmann::json());
    if (!marker.is_number() || !dictionary.is_string() || dictionary.get<std::string>().size() > 40)
      return make_error("invalid_request",
                        "a ChArUco board needs \"marker_m\" (a marker's side in metres, its black "
                        "border included) and \"dictionary\" (e.g. \"DICT_4X4_50\")");
    calib::CharucoBoardSpec board{cols + 1, rows + 1, spacing.get<double>(), marker.get<double>(),
                                  dictionary.get<std::string>()};
    if (Status s = calib::check_charuco_board(board); !s) return s.error();
    normalised["marker_m"] = marker;
    normalised["dictionary"] = dictionary;
  } else if (body.contains("marker_m") || body.contains("dictionary")) {
    return make_error("invalid_request",
                      "\"marker_m\" and \"dictionary\" describe a ChArUco board: use them with "
                      "\"detector\": \"charuco\"");
  }
  if (body.contains("pixel_um")) {
    const auto& pixel = body["pixel_um"];
    if (!pixel.is_number() || !(pixel.get<double>() > 0) || pixel.get<double>() > 100)
      return make_error("out_of_range", "pixel_um must be in (0, 100] micrometres");
    normalised["pixel_um"] = pixel;
  }
  normalised["inner_corners"] = {cols, rows};
  normalised["spacing_m"] = spacing;
  normalised["model"] = model;
  normalised["detector"] = detector;
  return normalised;
}

calib::CalibrateOptions calibration_options(const nlohmann::json& normalised) {
  calib::CalibrateOptions options;
  options.board.cols = normalised.at("inner_corners").at(0).get<int>();
  options.board.rows = normalised.at("inner_corners").at(1).get<int>();
  options.board.spacing_m = normalised.at("spacing_m").get<double>();
  options.model = normalised.value("model", "auto");
  options.detector = normalised.value("detector", "auto");
  options.charuco_marker_m = normalised.value("marker_m", 0.0);
  options.charuco_dictionary = normalised.value("dictionary", "");
  return options;
}

}  // namespace camlab::service
