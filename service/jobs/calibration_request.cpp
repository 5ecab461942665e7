#include "service/jobs/calibration_request.h"

#include <cstdint>

#include "calib/calibration_request.h"

namespace camlab::service {

namespace {

// An integer field within int's range. nlohmann reads 4294967310 as an unsigned integer
// whose get<int>() is 14: the range is checked on the 64-bit value it holds.
bool fits_int(const nlohmann::json& v) {
  if (v.is_number_unsigned()) return v.get<uint64_t>() <= uint64_t{INT32_MAX};
  return v.is_number_integer() && v.get<int64_t>() >= INT32_MIN && v.get<int64_t>() <= INT32_MAX;
}

}  // namespace

Result<nlohmann::json> normalised_calibration_fields(const nlohmann::json& body) {
  // The JSON's shape here (one code: invalid_request); every rule on the values once, in
  // calib::check_calibration_request, as `camlab calibrate` checks them.
  const nlohmann::json& corners = body.value("inner_corners", nlohmann::json());
  if (!corners.is_array() || corners.size() != 2 || !corners[0].is_number_integer() ||
      !corners[1].is_number_integer())
    return make_error("invalid_request", "\"inner_corners\" must be [COLS, ROWS], e.g. [14, 10]");
  if (!fits_int(corners[0]) || !fits_int(corners[1]))
    return make_error("out_of_range",
                      "the board's inner corners " + corners.dump() + " must be in [" +
                          std::to_string(calib::kBoardInnerCornersMin) + ", " +
                          std::to_string(calib::kBoardInnerCornersMax) + "] each way");
  const nlohmann::json& spacing = body.value("spacing_m", nlohmann::json());
  if (!spacing.is_number())
    return make_error("invalid_request", "\"spacing_m\" (corner spacing in metres) is required");
  const nlohmann::json& model = body.value("model", nlohmann::json("auto"));
  if (!model.is_string())
    return make_error("invalid_request",
                      "\"model\" must be \"auto\" or a mrcal LENSMODEL_... name");
  const nlohmann::json& detector = body.value("detector", nlohmann::json("auto"));
  if (!detector.is_string() || detector.get<std::string>().size() > 40)
    return make_error(
        "invalid_request",
        "\"detector\" must be \"auto\" (camlab's saddle-point detector, with mrgingham on "
        "square boards where it misses), \"saddle\", \"opencv\", \"mrgingham\", \"markers\" "
        "(a chessboard with OpenCV's three circle markers: boards cut by the frame are kept) or "
        "\"charuco\" (a ChArUco board: give marker_m and dictionary too)");
  const nlohmann::json& marker = body.value("marker_m", nlohmann::json(0.0));
  const nlohmann::json& dictionary = body.value("dictionary", nlohmann::json(""));
  if (!marker.is_number() || !dictionary.is_string() || dictionary.get<std::string>().size() > 40)
    return make_error(
        "invalid_request",
        "a ChArUco board's \"marker_m\" is a number (a marker's side in metres, its "
        "black border included) and its \"dictionary\" a name (e.g. \"DICT_4X4_50\")");
  const nlohmann::json& pixel = body.value("pixel_um", nlohmann::json(0.0));
  if (!pixel.is_number())
    return make_error("invalid_request", "\"pixel_um\" (pixel pitch in micrometres) is a number");
  if (body.contains("pixel_um") && pixel.get<double>() == 0)
    return make_error("out_of_range", "pixel_um must be positive (leave it out when unknown)");

  calib::CalibrateOptions options;
  options.board = {corners[0].get<int>(), corners[1].get<int>(), spacing.get<double>()};
  options.model = model.get<std::string>();
  options.detector = detector.get<std::string>();
  options.charuco_marker_m = marker.get<double>();
  options.charuco_dictionary = dictionary.get<std::string>();
  options.pixel_pitch_um = pixel.get<double>();
  if (Status s = calib::check_calibration_request(options, /*need_source=*/false); !s)
    return s.error();

  nlohmann::json normalised = nlohmann::json::object();
  normalised["inner_corners"] = {options.board.cols, options.board.rows};
  normalised["spacing_m"] = spacing;
  normalised["model"] = model;
  normalised["detector"] = detector;
  if (options.detector == "charuco") {
    normalised["marker_m"] = marker;
    normalised["dictionary"] = dictionary;
  }
  if (body.contains("pixel_um")) normalised["pixel_um"] = pixel;
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
