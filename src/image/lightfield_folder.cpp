#include "image/lightfield_folder.h"

#include <cmath>
#include <limits>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "base/atomic_file.h"
#include "image/pfm.h"
#include "image/png_encoder.h"

namespace camlab::image {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kDepthTruthFile = "truth_depth_m.pfm";

Error bad(const std::string& message) {
  return make_error("bad_manifest", std::string(kLightFieldFileName) + ": " + message);
}

// A finite number at `key` in [lo, hi] (lo exclusive when `open_lo`).
Result<double> number_at(const json& j, const char* key, double lo, double hi,
                         bool open_lo = false) {
  if (!j.contains(key) || !j[key].is_number()) return bad(std::string(key) + " must be a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v) || v > hi || (open_lo ? v <= lo : v < lo))
    return bad(std::string(key) + " = " + j[key].dump() + " is out of range " +
               (open_lo ? "(" : "[") + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

Result<int> integer_at(const json& j, const char* key, int lo, int hi) {
  if (!j.contains(key) || !j[key].is_number_integer())
    return bad(std::string(key) + " must be an integer");
  const long long v = j[key].get<long long>();
  if (v < lo || v > hi)
    return bad(std::string(key) + " = " + std::to_string(v) + " is out of range [" +
               std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return static_cast<int>(v);
}

template <size_t N>
Result<std::array<double, N>> numbers_at(const json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != N)
    return bad(std::string(key) + " must be an array of " + std::to_string(N) + " numbers");
  std::array<double, N> out{};
  for (size_t i = 0; i < N; ++i) {
    if (!j[key][i].is_number() || !std::isfinite(j[key][i].get<double>()))
      return bad(std::string(key) + "[" + std::to_string(i) + "] must be a finite number");
    out[i] = j[key][i].get<double>();
  }
  return out;
}

}  // namespace

LightFieldView view_of_cell(int u_index, int v_index, const std::array<double, 4>& cell,
                            const std::array<double, 2>& centroid, double area_share,
                            double radius_m) {
  LightFieldView v;
  v.u_index = u_index;
  v.v_index = v_index;
  v.centroid_m = {centroid[0] * radius_m, centroid[1] * radius_m};
  v.cell_m = {cell[0] * radius_m, cell[1] * radius_m, cell[2] * radius_m, cell[3] * radius_m};
  v.area_share = area_share;
  return v;
}

json to_json(const LightFieldDescription& d) {
  json views = json::array();
  for (const LightFieldView& v : d.views)
    views.push_back({{"frame", v.frame},
                     {"u_index", v.u_index},
                     {"v_index", v.v_index},
                     {"centroid_m", v.centroid_m},
                     {"cell_m", v.cell_m},
                     {"area_share", v.area_share}});
  const LightFieldOptics& o = d.optics;
  json out = {
      {"format", kLightFieldFormatName},
      {"version", kLightFieldFormatVersion},
      {"views_u", d.views_u},
      {"views_v", d.views_v},
      {"lattice",
       {{"layout", d.lattice.layout},
        {"row_pitch", d.lattice.row_pitch},
        {"odd_row_shift", d.lattice.odd_row_shift}}},
      {"optics",
       {{"focal_mm", o.focal_mm},
        {"f_number", o.f_number},
        {"lens_to_sensor_mm", o.lens_to_sensor_mm},
        {"focus_distance_m",
         std::isfinite(o.focus_distance_m) ? json(o.focus_distance_m) : json(nullptr)},
        {"pixel_pitch_um", o.pixel_pitch_um},
        {"principal_point_px", o.principal_point_px}}},
      {"views", views},
      {"lenslet", nullptr},
      {"truth", d.truth},
  };
  if (d.lenslet)
    out["lenslet"] = {{"image", d.lenslet->image},
                      {"white", d.lenslet->white},
                      {"bit_depth", d.lenslet->bit_depth},
                      {"black_level_dn", d.lenslet->black_level_dn},
                      {"raw_pixel_pitch_um", d.lenslet->raw_pixel_pitch_um},
                      {"settings", d.lenslet->settings}};
  return out;
}

Result<LightFieldDescription> light_field_description_from_json(const json& j) {
  if (!j.is_object() || j.value("format", "") != kLightFieldFormatName)
    return bad(std::string("format must be \"") + kLightFieldFormatName + "\"");
  if (!j.contains("version") || !j["version"].is_number_integer() ||
      j["version"].get<long long>() != kLightFieldFormatVersion)
    return make_error("unsupported_version",
                      std::string(kLightFieldFileName) + ": version " +
                          (j.contains("version") ? j["version"].dump() : "(none)") +
                          " is not one this camlab reads (" +
                          std::to_string(kLightFieldFormatVersion) + ")");
  LightFieldDescription d;
  CAMLAB_ASSIGN(d.views_u, integer_at(j, "views_u", 1, 64));
  CAMLAB_ASSIGN(d.views_v, integer_at(j, "views_v", 1, 64));
  if (!j.contains("lattice") || !j["lattice"].is_object()) return bad("lattice must be an object");
  const json& lattice = j["lattice"];
  d.lattice.layout = lattice.value("layout", "");
  if (d.lattice.layout != "square" && d.lattice.layout != "hex")
    return bad("lattice.layout must be \"square\" or \"hex\"");
  CAMLAB_ASSIGN(d.lattice.row_pitch, number_at(lattice, "row_pitch", 0, 4, true));
  CAMLAB_ASSIGN(d.lattice.odd_row_shift, number_at(lattice, "odd_row_shift", -1, 1));

  if (!j.contains("optics") || !j["optics"].is_object()) return bad("optics must be an object");
  const json& o = j["optics"];
  CAMLAB_ASSIGN(d.optics.focal_mm, number_at(o, "focal_mm", 0, 1e4, true));
  CAMLAB_ASSIGN(d.optics.f_number, number_at(o, "f_number", 0, 1e3, true));
  CAMLAB_ASSIGN(d.optics.lens_to_sensor_mm,
                number_at(o, "lens_to_sensor_mm", d.optics.focal_mm, 1e5));
  if (o.contains("focus_distance_m") && o["focus_distance_m"].is_null())
    d.optics.focus_distance_m = std::numeric_limits<double>::infinity();
  else
    CAMLAB_ASSIGN(d.optics.focus_distance_m, number_at(o, "focus_distance_m", 0, 1e12, true));
  CAMLAB_ASSIGN(d.optics.pixel_pitch_um, number_at(o, "pixel_pitch_um", 0, 1e4, true));
  CAMLAB_ASSIGN(d.optics.principal_point_px, numbers_at<2>(o, "principal_point_px"));

  if (!j.contains("views") || !j["views"].is_array() || j["views"].empty())
    return bad("views must be a non-empty array");
  std::set<std::pair<int, int>> seen;
  for (const json& v : j["views"]) {
    if (!v.is_object()) return bad("every view must be an object");
    LightFieldView view;
    CAMLAB_ASSIGN(view.frame, integer_at(v, "frame", 0, 1 << 20));
    CAMLAB_ASSIGN(view.u_index, integer_at(v, "u_index", 0, d.views_u - 1));
    CAMLAB_ASSIGN(view.v_index, integer_at(v, "v_index", 0, d.views_v - 1));
    CAMLAB_ASSIGN(view.centroid_m, numbers_at<2>(v, "centroid_m"));
    CAMLAB_ASSIGN(view.cell_m, numbers_at<4>(v, "cell_m"));
    CAMLAB_ASSIGN(view.area_share, number_at(v, "area_share", 0, 1));
    if (!seen.insert({view.u_index, view.v_index}).second)
      return bad("view (" + std::to_string(view.u_index) + ", " + std::to_string(view.v_index) +
                 ") is listed twice");
    d.views.push_back(view);
  }
  if (j.contains("lenslet") && !j["lenslet"].is_null()) {
    const json& l = j["lenslet"];
    if (!l.is_object()) return bad("lenslet must be an object or null");
    LensletInfo info;
    info.image = l.value("image", "");
    info.white = l.value("white", "");
    if (!is_plain_file_name(info.image) || !is_plain_file_name(info.white))
      return bad("lenslet.image and lenslet.white must name files in the folder");
    CAMLAB_ASSIGN(info.bit_depth, integer_at(l, "bit_depth", 1, 16));
    CAMLAB_ASSIGN(info.black_level_dn, integer_at(l, "black_level_dn", 0, 65535));
    CAMLAB_ASSIGN(info.raw_pixel_pitch_um, number_at(l, "raw_pixel_pitch_um", 0, 1e4, true));
    info.settings = l.value("settings", json::object());
    d.lenslet = info;
  }
  d.truth = j.value("truth", json());
  return d;
}

Result<LightFieldFolderWriter> LightFieldFolderWriter::create(const fs::path& dir,
                                                              const json& source,
                                                              const json& parameters) {
  auto capture = CaptureFolderWriter::create(dir, kLightFieldKind, source, parameters);
  if (!capture) return capture.error();
  return LightFieldFolderWriter(std::move(*capture));
}

Status LightFieldFolderWriter::add_view(const cv::Mat& image, const FrameSidecar& sidecar,
                                        LightFieldView view) {
  auto entry = capture_.add_frame(image, sidecar);
  if (!entry) return entry.error();
  view.frame = entry->index;
  views_.push_back(view);
  return {};
}

Status LightFieldFolderWriter::add_lenslet(const cv::Mat& raw, const cv::Mat& white,
                                           const LensletInfo& info) {
  const int depth = info.bit_depth <= 8 ? CV_8U : CV_16U;
  if (raw.empty() || raw.type() != depth || white.type() != depth || raw.size() != white.size())
    return make_error("bad_frame", "the lenslet and white images must be single-channel " +
                                       std::string(depth == CV_8U ? "8" : "16") +
                                       "-bit images of one size");
  PngEncoder png;
  for (auto [name, image] : {std::pair{info.image, &raw}, std::pair{info.white, &white}}) {
    auto bytes = png.encode(*image);
    if (!bytes) return bytes.error();
    if (Status s = capture_.add_file(
            name, std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()));
        !s)
      return s;
  }
  lenslet_ = info;
  return {};
}

Status LightFieldFolderWriter::add_depth_truth(const cv::Mat& depth_m) {
  if (depth_m.empty() || depth_m.type() != CV_32F)
    return make_error("bad_frame", "the depth truth must be a single-channel float image");
  if (Status s = capture_.add_file(kDepthTruthFile, encode_pfm(depth_m)); !s) return s;
  depth_file_ = kDepthTruthFile;
  return {};
}

Status LightFieldFolderWriter::finish(LightFieldDescription description) {
  if (views_.empty()) return make_error("invalid_argument", "a light field needs a view");
  description.views = views_;
  description.lenslet = lenslet_;
  if (!depth_file_.empty()) {
    if (!description.truth.is_object()) description.truth = json::object();
    description.truth["depth_m"] = depth_file_;
  }
  if (Status s = capture_.add_file(kLightFieldFileName, to_json(description).dump(2) + "\n"); !s)
    return s;
  return capture_.finish();
}

Result<LightFieldFolder> LightFieldFolder::open(const fs::path& dir) {
  auto capture = CaptureFolder::open(dir);
  if (!capture) return capture.error();
  const fs::path path = dir / kLightFieldFileName;
  std::error_code ec;
  if (!fs::exists(path, ec))
    return make_error("not_found", dir.string() +
                                       " is a capture folder but not a light field (no " +
                                       kLightFieldFileName + ")");
  auto text = read_text_file(path);
  if (!text) return text.error();
  const json j = json::parse(*text, nullptr, false);
  if (j.is_discarded()) return bad("not valid JSON");
  auto description = light_field_description_from_json(j);
  if (!description) return description.error();
  const int frames = static_cast<int>(capture->frames().size());
  for (const LightFieldView& v : description->views)
    if (v.frame >= frames)
      return bad("view (" + std::to_string(v.u_index) + ", " + std::to_string(v.v_index) +
                 ") names frame " + std::to_string(v.frame) + " of " + std::to_string(frames));
  return LightFieldFolder(std::move(*capture), std::move(*description));
}

Result<cv::Mat> LightFieldFolder::load_view(int k) const {
  if (k < 0 || k >= static_cast<int>(description_.views.size()))
    return make_error("out_of_range", "view " + std::to_string(k) + " is not in 0.." +
                                          std::to_string(description_.views.size() - 1));
  return capture_.load_image(description_.views[static_cast<size_t>(k)].frame);
}

Result<FrameSidecar> LightFieldFolder::load_view_sidecar(int k) const {
  if (k < 0 || k >= static_cast<int>(description_.views.size()))
    return make_error("out_of_range", "view " + std::to_string(k) + " is not in 0.." +
                                          std::to_string(description_.views.size() - 1));
  return capture_.load_sidecar(description_.views[static_cast<size_t>(k)].frame);
}

Result<std::pair<cv::Mat, cv::Mat>> LightFieldFolder::load_lenslet() const {
  if (!description_.lenslet)
    return make_error("not_found", capture_.dir().string() + " holds no lenslet image");
  std::pair<cv::Mat, cv::Mat> out;
  for (auto [name, image] : {std::pair{description_.lenslet->image, &out.first},
                             std::pair{description_.lenslet->white, &out.second}}) {
    *image = cv::imread((capture_.dir() / name).string(), cv::IMREAD_UNCHANGED);
    if (image->empty() || image->channels() != 1)
      return make_error("bad_image", (capture_.dir() / name).string() +
                                         " is missing or not a single-channel image");
  }
  if (out.first.size() != out.second.size())
    return make_error("bad_image", "the lenslet and white images differ in size");
  return out;
}

Result<cv::Mat> LightFieldFolder::load_depth_truth() const {
  const json& truth = description_.truth;
  if (!truth.is_object() || !truth.contains("depth_m") || !truth["depth_m"].is_string() ||
      !is_plain_file_name(truth["depth_m"].get<std::string>()))
    return make_error("not_found", capture_.dir().string() + " holds no depth truth");
  return read_pfm(capture_.dir() / truth["depth_m"].get<std::string>());
}

}  // namespace camlab::image
