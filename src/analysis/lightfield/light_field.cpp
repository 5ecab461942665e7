#include "analysis/lightfield/light_field.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/format.h"
#include "optics/optics.h"

namespace camlab::analysis::lightfield {

Result<LightField> load_light_field(const std::filesystem::path& dir) {
  auto folder = image::LightFieldFolder::open(dir);
  if (!folder) return folder.error();
  LightField lf;
  lf.description = folder->description();
  lf.source = folder->capture().manifest().value("source", nlohmann::json::object());
  for (int k = 0; k < static_cast<int>(lf.description.views.size()); ++k) {
    auto sidecar = folder->load_view_sidecar(k);
    if (!sidecar) return sidecar.error();
    const std::string what = "view " + std::to_string(k) + " of " + dir.string();
    if (Status ok = image::check_mono_linear(*sidecar, what); !ok) return ok.error();
    auto image = folder->load_view(k);
    if (!image) return image.error();
    if (!lf.views.empty() && image->size() != lf.views.front().size())
      return make_error("bad_frame", what + " is " + std::to_string(image->cols) + "x" +
                                         std::to_string(image->rows) + ", the first view " +
                                         std::to_string(lf.views.front().cols) + "x" +
                                         std::to_string(lf.views.front().rows));
    if (k == 0) {
      lf.bit_depth = sidecar->bit_depth;
      lf.black_level_dn = sidecar->black_level_dn;
      lf.settings = sidecar->settings;
    }
    cv::Mat signal;
    image->convertTo(signal, CV_32F, 1.0, -sidecar->black_level_dn);
    lf.views.push_back(signal);
  }
  return lf;
}

ViewGeometry view_geometry(const image::LightFieldDescription& d) {
  ViewGeometry g;
  const image::LightFieldOptics& o = d.optics;
  g.f_px = o.lens_to_sensor_mm / (o.pixel_pitch_um * 1e-3);
  g.inverse_focus_per_m = std::isfinite(o.focus_distance_m) ? 1 / o.focus_distance_m : 0.0;
  g.focal_mm = o.focal_mm;
  g.lens_to_sensor_mm = o.lens_to_sensor_mm;
  g.aperture_radius_m = o.focal_mm / o.f_number / 2 * 1e-3;
  g.cell_pitch_m = 2 * g.aperture_radius_m / std::min(d.views_u, d.views_v);
  g.principal_point_px = o.principal_point_px;
  return g;
}

Result<double> refocus_lens_to_sensor_mm(const ViewGeometry& g, double focus_m) {
  if (!(focus_m > 0))
    return make_error("out_of_range", "focus_m = " + format_significant(focus_m) +
                                          (std::isnan(focus_m) ? "" : " is behind the lens") +
                                          ": a focus distance must be above the focal length (" +
                                          format_significant(g.focal_mm * 1e-3) + " m), or inf");
  auto z_r = optics::lens_to_sensor_mm(g.focal_mm, focus_m * 1e3);
  if (!z_r)
    return make_error(z_r.error().code, "focus_m = " + format_significant(focus_m) +
                                            " is not above the focal length (" +
                                            format_significant(g.focal_mm * 1e-3) +
                                            " m): the lens forms no real image of it");
  return *z_r;
}

}  // namespace camlab::analysis::lightfield
