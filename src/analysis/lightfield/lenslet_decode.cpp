#include "analysis/lightfield/lenslet_decode.h"

#include <algorithm>
#include <cmath>

#include "base/format.h"
#include "image/pixel_format.h"
#include "optics/aperture_cells.h"

namespace camlab::analysis::lightfield {

namespace {

// Bilinear interpolation at (x, y) (pixel centres at integers), edges repeated.
double bilinear(const cv::Mat& image, double x, double y) {
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, image.cols - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, image.rows - 1);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const double a = std::clamp(x - x0, 0.0, 1.0), b = std::clamp(y - y0, 0.0, 1.0);
  const auto at = [&](int xx, int yy) { return static_cast<double>(image.at<float>(yy, xx)); };
  return (1 - b) * ((1 - a) * at(x0, y0) + a * at(x1, y0)) +
         b * ((1 - a) * at(x0, y1) + a * at(x1, y1));
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

Result<DecodedLightField> decode_lenslet(const cv::Mat& raw, const cv::Mat& white,
                                         int black_level_dn, const image::LightFieldOptics& optics,
                                         double raw_pixel_pitch_um, const DecodeOptions& options) {
  if (raw.empty() || raw.size() != white.size() || raw.type() != white.type() ||
      raw.channels() != 1)
    return make_error("invalid_argument",
                      "the lenslet and white images must be single-channel images of one size "
                      "and type");
  if (!(options.min_lit_share >= 0 && options.min_lit_share <= 1))
    return make_error(
        "invalid_argument",
        "min_lit_share = " + format_significant(options.min_lit_share) + " is out of range [0, 1]");
  DecodedLightField out;
  CAMLAB_ASSIGN(out.lattice, find_microlens_lattice(white, black_level_dn));
  const MicrolensLattice& lattice = out.lattice;
  const double pitch = lattice.pitch_px();
  const int u = static_cast<int>(std::lround(pitch));
  if (u < 2)
    return make_error("invalid_argument", "the microlens pitch is " + format_significant(pitch, 3) +
                                              " px: at least 2 px are needed for 2 x 2 views");
  out.views_per_side = u;
  if (lattice.fit_rms_px > 0.1)
    out.warnings.push_back(format_printf(
        "the microlens centres stray %.3f px RMS from the fitted lattice (more than 0.1 px): "
        "the views mix neighbouring cells",
        lattice.fit_rms_px));
  if (std::fabs(pitch - u) > 0.01)
    out.warnings.push_back(format_printf(
        "the microlens pitch is %.3f px, not a whole number: the views are interpolated "
        "between raw pixels (an approximation)",
        pitch));

  cv::Mat raw_signal, white_signal;
  raw.convertTo(raw_signal, CV_32F, 1.0, -black_level_dn);
  white.convertTo(white_signal, CV_32F, 1.0, -black_level_dn);
  const double along[2] = {lattice.e1_px[0] / pitch, lattice.e1_px[1] / pitch};
  const double across[2] = {-along[1], along[0]};
  std::vector<double> centre_white;
  for (int l = 0; l < lattice.rows; ++l)
    for (int k = 0; k < lattice.columns; ++k) {
      const auto c = lattice.centre(k, l);
      centre_white.push_back(bilinear(white_signal, c[0], c[1]));
    }
  out.full_white_dn = median(centre_white);
  if (!(out.full_white_dn > 0))
    return make_error("no_signal", "the white image is dark at the microlens centres");

  // Where the neighbouring microlenses' images lie, from a microlens in either row parity:
  // a cell whose raw pixel reaches into one (a disk of half a pitch) mixes its light.
  std::vector<std::array<double, 2>> neighbours;
  const int k_mid = lattice.columns / 2, l_mid = lattice.rows / 2;
  for (int parity = 0; parity < 2 && l_mid + parity < lattice.rows; ++parity) {
    const auto c = lattice.centre(k_mid, l_mid + parity);
    for (int dl = -2; dl <= 2; ++dl)
      for (int dk = -2; dk <= 2; ++dk) {
        if (dl == 0 && dk == 0) continue;
        const auto n = lattice.centre(k_mid + dk, l_mid + parity + dl);
        neighbours.push_back({n[0] - c[0], n[1] - c[1]});
      }
  }
  const auto reaches_neighbour = [&](const double offset[2]) {
    for (const auto& n : neighbours) {
      const double dx = std::max(std::fabs(n[0] - offset[0]) - 0.5, 0.0);
      const double dy = std::max(std::fabs(n[1] - offset[1]) - 0.5, 0.0);
      if (std::hypot(dx, dy) < pitch / 2 - 1e-9) return true;
    }
    return false;
  };
  const double radius_m = optics.focal_mm / optics.f_number / 2 * 1e-3;
  std::vector<optics::ApertureCell> cells;
  CAMLAB_ASSIGN(cells, optics::aperture_cells(u, u));
  image::LightFieldDescription& d = out.light_field.description;
  for (const optics::ApertureCell& cell : cells) {
    if (cell.area_share <= 0) {
      ++out.cells_left_out;
      continue;
    }
    // The aperture is imaged mirrored: cell i lies (U-1)/2 - i cell steps from the centre.
    const double a = ((u - 1) / 2.0 - cell.u_index) * pitch / u;
    const double b = ((u - 1) / 2.0 - cell.v_index) * pitch / u;
    const double offset[2] = {a * along[0] + b * across[0], a * along[1] + b * across[1]};
    if (reaches_neighbour(offset)) {
      ++out.cells_left_out;
      continue;
    }
    cv::Mat view(lattice.rows, lattice.columns, CV_32F);
    std::vector<double> lit;
    lit.reserve(static_cast<size_t>(lattice.rows) * lattice.columns);
    for (int l = 0; l < lattice.rows; ++l)
      for (int k = 0; k < lattice.columns; ++k) {
        const auto c = lattice.centre(k, l);
        const double x = c[0] + offset[0], y = c[1] + offset[1];
        const double w = bilinear(white_signal, x, y);
        lit.push_back(w / out.full_white_dn);
        view.at<float>(l, k) =
            w > 0 ? static_cast<float>(bilinear(raw_signal, x, y) * out.full_white_dn / w) : 0.f;
      }
    const double lit_share = median(lit);
    if (!(lit_share >= options.min_lit_share) || lit_share <= 0) {
      ++out.cells_left_out;
      continue;
    }
    d.views.push_back(
        image::view_of_cell(cell.u_index, cell.v_index, {cell.x0, cell.x1, cell.y0, cell.y1},
                            {cell.centroid_x, cell.centroid_y}, cell.area_share, radius_m));
    out.light_field.views.push_back(view);
    out.lit_share.push_back(lit_share);
  }
  if (d.views.empty())
    return make_error("no_signal", "no cell behind the microlenses is lit at min_lit_share " +
                                       format_significant(options.min_lit_share));
  d.views_u = d.views_v = u;
  d.lattice.layout = lattice.staggered ? "hex" : "square";
  d.lattice.row_pitch = lattice.row_pitch();
  d.lattice.odd_row_shift = lattice.staggered ? lattice.odd_row_shift() : 0.0;
  d.optics = optics;
  d.optics.pixel_pitch_um = raw_pixel_pitch_um * pitch;
  // The optical axis is taken at the middle of the microlenses found (what a decoder
  // without a calibration of it assumes).
  d.optics.principal_point_px = {
      (lattice.columns - 1) / 2.0 + (lattice.rows > 1 ? 0.5 * d.lattice.odd_row_shift : 0.0),
      (lattice.rows - 1) * d.lattice.row_pitch / 2};
  out.light_field.black_level_dn = black_level_dn;
  return out;
}

Result<DecodedLightField> decode_lenslet_folder(const std::filesystem::path& dir,
                                                const std::filesystem::path& out_dir,
                                                const DecodeOptions& options) {
  auto folder = image::LightFieldFolder::open(dir);
  if (!folder) return folder.error();
  const image::LightFieldDescription& in = folder->description();
  if (!in.lenslet)
    return make_error("not_found", dir.string() + " holds no lenslet image (" +
                                       image::kLightFieldFileName + " has no lenslet)");
  auto images = folder->load_lenslet();
  if (!images) return images.error();
  DecodedLightField decoded;
  CAMLAB_ASSIGN(decoded, decode_lenslet(images->first, images->second, in.lenslet->black_level_dn,
                                        in.optics, in.lenslet->raw_pixel_pitch_um, options));
  LightField& lf = decoded.light_field;
  lf.bit_depth = in.lenslet->bit_depth;
  lf.settings = in.lenslet->settings;
  lf.source = folder->capture().manifest().value("source", nlohmann::json::object());

  const nlohmann::json parameters = {{"decoded_from", dir.string()},
                                     {"min_lit_share", options.min_lit_share},
                                     {"microlens_lattice", to_json(decoded.lattice)},
                                     {"full_white_dn", decoded.full_white_dn}};
  auto writer = image::LightFieldFolderWriter::create(out_dir, lf.source, parameters);
  if (!writer) return writer.error();
  const int max_dn = (1 << lf.bit_depth) - 1;
  for (size_t k = 0; k < lf.views.size(); ++k) {
    cv::Mat dn;
    lf.views[k].convertTo(dn, lf.bit_depth <= 8 ? CV_8U : CV_16U, 1.0, lf.black_level_dn);
    cv::min(dn, max_dn, dn);
    image::FrameSidecar sidecar;
    sidecar.sequence = k;
    sidecar.clock = "virtual";
    sidecar.pixel_format = std::string(image::mono_pixel_format(lf.bit_depth));
    sidecar.bit_depth = lf.bit_depth;
    sidecar.black_level_dn = lf.black_level_dn;
    sidecar.settings = lf.settings;
    const image::LightFieldView& v = lf.description.views[k];
    sidecar.labels = {
        {"u_index", v.u_index}, {"v_index", v.v_index}, {"lit_share", decoded.lit_share[k]}};
    if (Status s = writer->add_view(dn, sidecar, v); !s) return s.error();
  }
  if (Status s = writer->finish(lf.description); !s) return s.error();
  return decoded;
}

}  // namespace camlab::analysis::lightfield
