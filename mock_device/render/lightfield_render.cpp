#include "mock_device/render/lightfield_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <thread>

#include "image/pixel_format.h"
#include "mock_device/render/aperture_region.h"
#include "mock_device/render/chief_ray_table.h"
#include "mock_device/render/sampling.h"
#include "mock_device/render/sensor_model.h"
#include "optics/aperture_cells.h"
#include "optics/optics.h"

namespace camlab::mock {

namespace {

// The white image's level for a fully lit raw pixel, as a share of the DN range above
// black: a flat field exposed well below clipping.
constexpr double kWhiteLevel = 0.8;

// Rows of a hexagonal grid's microlens images: ceil(U sqrt(3) / 2) raw pixels apart, the
// nearest whole-pixel pitch at which round images of diameter U do not overlap.
int hex_row_pitch_px(int views) {
  return static_cast<int>(std::ceil(views * std::sqrt(3.0) / 2 - 1e-9));
}

// Where the microlens of view pixel (k, l) puts its U x U block of raw pixels.
struct LensletGeometry {
  int views = 0;             // U: raw pixels per microlens image side
  int row_pitch_px = 0;      // raw pixels between rows of microlens images
  int odd_row_shift_px = 0;  // odd rows' shift (raw pixels)
  int margin_px = 0;
  cv::Size raw_size;
  cv::Point block_origin(int k, int l) const {
    return {margin_px + k * views + (l % 2) * odd_row_shift_px, margin_px + l * row_pitch_px};
  }
};

LensletGeometry lenslet_geometry(const LightFieldSpec& lf, int width, int height) {
  LensletGeometry g;
  g.views = lf.views_u;
  g.margin_px = lf.lenslet_margin_px;
  const bool hex = lf.microlens_grid == "hex";
  g.row_pitch_px = hex ? hex_row_pitch_px(g.views) : g.views;
  g.odd_row_shift_px = hex ? g.views / 2 : 0;
  g.raw_size = {2 * g.margin_px + width * g.views + (hex ? g.odd_row_shift_px : 0),
                2 * g.margin_px + (height - 1) * g.row_pitch_px + g.views};
  return g;
}

// The chief-ray table of one row parity of a hexagonal lattice: view pixel (k, l) sits at
// (k + (l odd ? 1/2 : 0), l r) camera pixels, r the lattice's row pitch; the optical axis
// at the lattice's centre (the spec's principal point + (1/4, 0), rows scaled by r).
Result<ChiefRayTable> hex_rays(const CameraSpec& camera, double lens_to_sensor_mm, double r,
                               bool odd_rows) {
  std::vector<double> intrinsics = intrinsics_at(camera, lens_to_sensor_mm);
  intrinsics[1] = intrinsics[0] / r;  // fy: a lattice row is r camera pixels
  intrinsics[2] = camera.lens.principal_point_px[0] + 0.25 - (odd_rows ? 0.5 : 0.0);
  intrinsics[3] = camera.lens.principal_point_px[1];  // cy r / r
  return ChiefRayTable::create(camera.lens.model, intrinsics, camera.sensor.width_px,
                               camera.sensor.height_px);
}

// The n planes interleaved in `values` (height x width n), one image each.
std::vector<cv::Mat> split_values(const cv::Mat& values, int n) {
  std::vector<cv::Mat> planes(static_cast<size_t>(n));
  if (n == 1) {
    planes[0] = values;
    return planes;
  }
  cv::Mat interleaved = values.reshape(n);
  for (int k = 0; k < n; ++k) cv::extractChannel(interleaved, planes[static_cast<size_t>(k)], k);
  return planes;
}

}  // namespace

Result<LightFieldFrame> render_light_field(Renderer& renderer, const RenderSettings& settings,
                                           int view, const RenderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const CameraSpec& camera = renderer.camera();
  const LightFieldSpec& lf = camera.lightfield;
  if (!lf.enabled())
    return make_error("invalid_argument",
                      "camera spec '" + camera.name +
                          "' has no lightfield block (docs/virtual-camera.md, \"Light fields\")");
  if (Status ok = renderer.validate(settings); !ok) return ok.error();
  std::vector<optics::ApertureCell> all_cells;
  CAMLAB_ASSIGN(all_cells, optics::aperture_cells(lf.views_u, lf.views_v));
  std::vector<optics::ApertureCell> cells;
  std::vector<ApertureRegion> regions;
  for (const optics::ApertureCell& c : all_cells) {
    ApertureRegion region(c.x0, c.x1, c.y0, c.y1);
    if (region.empty()) continue;
    cells.push_back(c);
    regions.push_back(region);
  }
  const int n = static_cast<int>(regions.size());
  const double lens_to_sensor_mm =
      camera.lens.focal_mm + settings.focus_position * camera.lens.focus.extension_mm_per_step;
  const double radius_m = camera.lens.focal_mm / settings.f_number / 2 * 1e-3;
  const int width = camera.sensor.width_px, height = camera.sensor.height_px;
  const bool hex = lf.microlens_grid == "hex";
  const LensletGeometry geometry = lenslet_geometry(lf, width, height);
  const double row_pitch = hex ? static_cast<double>(geometry.row_pitch_px) / lf.views_u : 1.0;

  LightFieldFrame frame;
  LightFieldCells request{&regions, std::max(lf.views_u, lf.views_v), nullptr};
  LightFieldIntegral integral;
  if (!hex) {
    CAMLAB_ASSIGN(integral, renderer.integrate_light_field(settings, view, options, request));
  } else {
    // Even and odd rows of the staggered lattice from tables of their own.
    LightFieldIntegral parts[2];
    for (int parity = 0; parity < 2; ++parity) {
      auto rays = hex_rays(camera, lens_to_sensor_mm, row_pitch, parity == 1);
      if (!rays) return rays.error();
      request.rays = &*rays;
      CAMLAB_ASSIGN(parts[parity],
                    renderer.integrate_light_field(settings, view, options, request));
    }
    integral = parts[0];
    for (int y = 1; y < height; y += 2) {
      parts[1].values.row(y).copyTo(integral.values.row(y));
      parts[1].depth_m.row(y).copyTo(integral.depth_m.row(y));
    }
    integral.stats.seconds += parts[1].stats.seconds;
  }

  const std::vector<cv::Mat> planes = split_values(integral.values, n);
  const int threads = options.threads > 0
                          ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int k = 0; k < n; ++k)
    frame.views.push_back(
        expose(planes[static_cast<size_t>(k)], camera, integral.electrons_per_unit_reflectance,
               settings.gain, options.noise,
               mix_seed(options.seed, options.frame_number * 4096 + 2 * k + 3), threads));
  frame.depth_m = integral.depth_m;
  frame.settings = integral.settings;
  frame.truth = integral.truth;

  image::LightFieldDescription& d = frame.description;
  d.views_u = lf.views_u;
  d.views_v = lf.views_v;
  d.lattice.layout = hex ? "hex" : "square";
  d.lattice.row_pitch = row_pitch;
  d.lattice.odd_row_shift = hex ? 0.5 : 0.0;
  auto focus_mm = optics::focus_distance_mm(camera.lens.focal_mm, lens_to_sensor_mm);
  if (!focus_mm) return focus_mm.error();
  d.optics = {camera.lens.focal_mm,
              settings.f_number,
              lens_to_sensor_mm,
              *focus_mm * 1e-3,
              camera.sensor.pixel_pitch_um,
              {camera.lens.principal_point_px[0] + (hex ? 0.25 : 0.0),
               camera.lens.principal_point_px[1] * row_pitch}};
  for (const optics::ApertureCell& c : cells) {
    d.views.push_back(image::view_of_cell(c.u_index, c.v_index, {c.x0, c.x1, c.y0, c.y1},
                                          {c.centroid_x, c.centroid_y}, c.area_share, radius_m));
  }
  d.truth = {{"microlens_grid", lf.microlens_grid}};

  if (lf.has_lenslet()) {
    // Each microlens's block of raw pixels, mirrored, lit by its cell's share; blocks of
    // adjacent hexagonal rows overlap in pixels outside both images, or share the
    // light of two cells at the rim.
    const int u = geometry.views;
    cv::Mat raw(geometry.raw_size, CV_32F, cv::Scalar(0));
    cv::Mat lit(geometry.raw_size, CV_32F, cv::Scalar(0));
    for (int k = 0; k < n; ++k) {
      const optics::ApertureCell& c = cells[static_cast<size_t>(k)];
      const int a = u - 1 - c.u_index, b = u - 1 - c.v_index;
      const float share = static_cast<float>(c.lit_share);
      const cv::Mat& plane = planes[static_cast<size_t>(k)];
      for (int l = 0; l < height; ++l)
        for (int m = 0; m < width; ++m) {
          const cv::Point o = geometry.block_origin(m, l);
          raw.at<float>(o.y + b, o.x + a) += share * plane.at<float>(l, m);
          lit.at<float>(o.y + b, o.x + a) += share;
        }
    }
    frame.lenslet =
        expose(raw, camera, integral.electrons_per_unit_reflectance, settings.gain, options.noise,
               mix_seed(options.seed, options.frame_number * 4096 + 1), threads);
    const SensorSpec& sensor = camera.sensor;
    const double max_dn = (1 << sensor.bit_depth) - 1;
    cv::Mat white_dn;
    lit.convertTo(white_dn, CV_64F, kWhiteLevel * (max_dn - sensor.black_level_dn),
                  sensor.black_level_dn);
    white_dn.convertTo(frame.white, sensor.bit_depth <= 8 ? CV_8U : CV_16U);  // rounds, clips
    image::LensletInfo info;
    info.bit_depth = sensor.bit_depth;
    info.black_level_dn = sensor.black_level_dn;
    info.raw_pixel_pitch_um = sensor.pixel_pitch_um / u;  // U raw pixels per microlens
    info.settings = frame.settings;
    d.lenslet = info;
    const cv::Point first = geometry.block_origin(0, 0);
    d.truth["microlens"] = {{"views_per_side", u},
                            {"pitch_px", u},
                            {"row_pitch_px", geometry.row_pitch_px},
                            {"odd_row_shift_px", geometry.odd_row_shift_px},
                            {"margin_px", geometry.margin_px},
                            {"first_centre_px", {first.x + (u - 1) / 2.0, first.y + (u - 1) / 2.0}},
                            {"white_level", kWhiteLevel}};
  }
  frame.stats = integral.stats;
  frame.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return frame;
}

Status write_light_field(const LightFieldFrame& frame, const Renderer& renderer,
                         const std::filesystem::path& out_dir, const RenderOptions& options) {
  const CameraSpec& camera = renderer.camera();
  const nlohmann::json source = {{"backend", "virtual"},
                                 {"camera", camera.name},
                                 {"camera_spec", camera.source},
                                 {"scene_spec", renderer.scene().source}};
  const nlohmann::json parameters = {{"seed", options.seed}, {"noise", options.noise}};
  auto writer = image::LightFieldFolderWriter::create(out_dir, source, parameters);
  if (!writer) return writer.error();
  const image::LightFieldDescription& d = frame.description;
  for (size_t k = 0; k < frame.views.size(); ++k) {
    const image::LightFieldView& v = d.views[k];
    image::FrameSidecar sidecar;
    sidecar.sequence = k;
    sidecar.timestamp_ns = 0;  // one exposure: every view is the same instant
    sidecar.clock = "virtual";
    sidecar.pixel_format = std::string(image::mono_pixel_format(camera.sensor.bit_depth));
    sidecar.bit_depth = camera.sensor.bit_depth;
    sidecar.black_level_dn = camera.sensor.black_level_dn;
    sidecar.settings = frame.settings;
    sidecar.labels = {{"u_index", v.u_index}, {"v_index", v.v_index}};
    sidecar.truth = frame.truth;
    sidecar.truth["lightfield_view"] = {{"u_index", v.u_index},
                                        {"v_index", v.v_index},
                                        {"centroid_m", v.centroid_m},
                                        {"cell_m", v.cell_m},
                                        {"area_share", v.area_share}};
    if (Status s = writer->add_view(frame.views[k], sidecar, v); !s) return s;
  }
  if (!frame.lenslet.empty())
    if (Status s = writer->add_lenslet(frame.lenslet, frame.white, *d.lenslet); !s) return s;
  if (Status s = writer->add_depth_truth(frame.depth_m); !s) return s;
  return writer->finish(d);
}

}  // namespace camlab::mock
