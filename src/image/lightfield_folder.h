// The light-field folder (docs/lightfield-folder.md): a capture folder (kind "lightfield",
// docs/capture-folder.md) whose frames are the sub-aperture views of one light field, and
// beside them
//
//   DIR/lightfield.json        the views' geometry: the grid of aperture cells, each view's
//                              cell and effective lens point (m), the lattice of the view
//                              pixels, the camera's optics (focal length, f-number,
//                              lens-to-sensor distance, pixel pitch, principal point)
//   DIR/lenslet.png            the raw lenslet image a plenoptic sensor records (optional)
//   DIR/white.png              its white (flat-field) image
//   DIR/truth_depth_m.pfm      the virtual camera's truth: the depth (m) each view pixel's
//                              chief ray meets, 32-bit float PFM, 0 = no surface (optional)
//
// Views are stored as any capture frame (16-bit PNG above 8 bits, raw DN with the black
// level in), so every tool that reads a capture folder reads the views too.
//
// LightFieldFolderWriter is thread-bound; reading is reentrant.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::image {

inline constexpr const char* kLightFieldFileName = "lightfield.json";
inline constexpr const char* kLightFieldFormatName = "camlab-lightfield";
inline constexpr int kLightFieldFormatVersion = 1;
inline constexpr const char* kLightFieldKind = "lightfield";

// One sub-aperture view: the image through cell (u_index, v_index) of the aperture grid.
// Lens coordinates are in metres on the lens, x and y along the sensor's x and y, 0 at the
// lens centre.
struct LightFieldView {
  int frame = 0;  // its frame in the capture folder
  int u_index = 0, v_index = 0;
  std::array<double, 2> centroid_m{0, 0};    // effective lens point: the lit part's centroid
  std::array<double, 4> cell_m{0, 0, 0, 0};  // x0, x1, y0, y1 of the square cell
  double area_share = 0;                     // of the aperture's area, 0..1
};

// The view of cell (u_index, v_index) from its geometry in units of the aperture radius
// (src/optics/aperture_cells.h): the cell's x0, x1, y0, y1, the centroid of its part
// inside the disk and its share of the disk, with lengths scaled to metres by radius_m.
LightFieldView view_of_cell(int u_index, int v_index, const std::array<double, 4>& cell,
                            const std::array<double, 2>& centroid, double area_share,
                            double radius_m);

// Where the view pixels sit, in view pixels (one microlens pitch): row r at
// y = r row_pitch, pixel k of it at x = k + (r odd ? odd_row_shift : 0). A square grid is
// row_pitch 1, shift 0; a hexagonal one staggers its rows.
struct ViewLattice {
  std::string layout = "square";  // "square" or "hex"
  double row_pitch = 1.0;
  double odd_row_shift = 0.0;
};

// The camera's optics when the views were taken: what refocusing needs to turn a focus
// distance into shifts. Distances in the units of their names; focus_distance_m may be
// +infinity (JSON null).
struct LightFieldOptics {
  double focal_mm = 0;
  double f_number = 0;
  double lens_to_sensor_mm = 0;
  double focus_distance_m = 0;
  double pixel_pitch_um = 0;                       // of the view pixels (the microlens pitch)
  std::array<double, 2> principal_point_px{0, 0};  // in view pixels, lattice coordinates
};

// The raw lenslet image and its white image: what a plenoptic camera delivers.
struct LensletInfo {
  std::string image = "lenslet.png";
  std::string white = "white.png";
  int bit_depth = 8;
  int black_level_dn = 0;
  double raw_pixel_pitch_um = 0;                       // the raw sensor's pixel pitch
  nlohmann::json settings = nlohmann::json::object();  // as a frame's sidecar has them
};

struct LightFieldDescription {
  int views_u = 0, views_v = 0;  // the aperture grid's cells per side
  ViewLattice lattice;
  LightFieldOptics optics;
  std::vector<LightFieldView> views;  // the non-empty cells, each once
  std::optional<LensletInfo> lenslet;
  // null, or the virtual camera's truth beyond the frames' sidecars (the depth file's
  // name, the microlens grid).
  nlohmann::json truth;
};

nlohmann::json to_json(const LightFieldDescription& description);
// Errors: "bad_manifest" naming the key, the value and what is allowed.
Result<LightFieldDescription> light_field_description_from_json(const nlohmann::json& json);

class LightFieldFolderWriter {
 public:
  // Creates the folder as CaptureFolderWriter::create does, of kind "lightfield".
  static Result<LightFieldFolderWriter> create(const std::filesystem::path& dir,
                                               const nlohmann::json& source,
                                               const nlohmann::json& parameters);

  // Writes one view as the next frame (`view.frame` is set to its index).
  Status add_view(const cv::Mat& image, const FrameSidecar& sidecar, LightFieldView view);
  // Writes the raw lenslet image and the white image (CV_8U for bit depth <= 8, else
  // CV_16U; the same size).
  Status add_lenslet(const cv::Mat& raw, const cv::Mat& white, const LensletInfo& info);
  // Writes the depth truth (CV_32F, metres, 0 = no surface).
  Status add_depth_truth(const cv::Mat& depth_m);
  // Writes lightfield.json (the views added, the lenslet and depth files written) and
  // marks the capture complete. Errors: "invalid_argument" when no view was added.
  Status finish(LightFieldDescription description);

  const std::filesystem::path& dir() const { return capture_.dir(); }

 private:
  explicit LightFieldFolderWriter(CaptureFolderWriter capture) : capture_(std::move(capture)) {}
  CaptureFolderWriter capture_;
  std::vector<LightFieldView> views_;
  std::optional<LensletInfo> lenslet_;
  std::string depth_file_;
};

class LightFieldFolder {
 public:
  // Opens the capture folder and lightfield.json; checks that every view names a frame
  // the folder lists. Errors: "not_a_capture", "bad_manifest", "io_error", "not_found"
  // (no lightfield.json: a capture folder that is not a light field).
  static Result<LightFieldFolder> open(const std::filesystem::path& dir);

  const LightFieldDescription& description() const { return description_; }
  const CaptureFolder& capture() const { return capture_; }

  // View k (of description().views): its DN as stored, and its sidecar.
  Result<cv::Mat> load_view(int k) const;
  Result<FrameSidecar> load_view_sidecar(int k) const;
  // The raw lenslet image and the white image, as stored. Errors: "not_found" without.
  Result<std::pair<cv::Mat, cv::Mat>> load_lenslet() const;
  // The depth truth (CV_32F, metres). Errors: "not_found" without.
  Result<cv::Mat> load_depth_truth() const;

 private:
  LightFieldFolder(CaptureFolder capture, LightFieldDescription description)
      : capture_(std::move(capture)), description_(std::move(description)) {}
  CaptureFolder capture_;
  LightFieldDescription description_;
};

}  // namespace camlab::image
