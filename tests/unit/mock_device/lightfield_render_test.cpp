// The virtual light-field camera (lightfield_render.h) against truth written out here:
// the view through each aperture cell of a straight edge, integrated by brute force over
// the cell and in closed form over the pixel, on a square and a hexagonal lattice; the
// views' area-weighted mean against the thin-lens render; the raw lenslet image and white
// image against the views and the cells' lit shares; the depth truth; and the spec's
// refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "mock_device/render/aperture_region.h"
#include "mock_device/render/lightfield_render.h"
#include "optics/aperture_cells.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

using nlohmann::json;

json lightfield_camera(int width, int height, int views, const char* grid) {
  json camera = testing::pinhole_camera_json(width, height);
  camera["lightfield"] = {{"views", {views, views}}, {"microlens_grid", grid}};
  return camera;
}

// A vertical edge (dark on -x, light on +x) on a fronto-parallel plane at z_m, the edge
// at x = edge_x_m, filling the view.
json edge_scene(double z_m, double edge_x_m) {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", 0.18},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {2.0, 2.0}},
             {"angle_deg", 0.0},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.8},
             {"pose", {{"position_m", {edge_x_m, 0.0, z_m}}}}}}}};
}

// The truth of one view pixel: a sensor point x (px, from the optical axis) sees through
// lens point o (metres) the scene point z m + o (1 - z q) (physics.md, "Light fields":
// the ray from o towards where the chief ray meets the plane of focus), light where its
// x passes the edge. Over the pixel's width the share is a clamp in closed form; over
// the cell (the disk inside a rectangle) a 300 x 300 midpoint grid.
double edge_view_truth(double x_px, double fx_px, double z_m, double q_per_m, double edge_x_m,
                       const optics::ApertureCell& cell, double radius_m) {
  const int n = 300;
  double inside = 0, light = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double u = cell.x0 + (i + 0.5) * (cell.x1 - cell.x0) / n;
      const double v = cell.y0 + (j + 0.5) * (cell.y1 - cell.y0) / n;
      if (u * u + v * v > 1) continue;
      inside += 1;
      // Light where z (x'/fx) + o_x (1 - z q) > edge: x' > threshold.
      const double threshold = fx_px * (edge_x_m - u * radius_m * (1 - z_m * q_per_m)) / z_m;
      light += std::clamp(x_px + 0.5 - threshold, 0.0, 1.0);
    }
  return 0.1 + 0.7 * light / inside;
}

void check_edge_views(const char* grid, int views) {
  const int width = 48, height = 16;
  const double z_m = 0.6, edge_x_m = 0.0004;
  Renderer renderer = testing::make_renderer(lightfield_camera(width, height, views, grid),
                                             edge_scene(z_m, edge_x_m));
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 2.0;
  settings.focus_position = 65;  // z_s = 8.065 mm: focused at 0.99 m
  RenderOptions options;
  options.noise = false;
  options.threads = 1;
  auto cells = optics::aperture_cells(views, views);
  ASSERT_TRUE(cells.ok());
  std::vector<ApertureRegion> regions;
  std::vector<optics::ApertureCell> kept;
  for (const auto& c : *cells)
    if (c.area_share > 0) {
      regions.emplace_back(c.x0, c.x1, c.y0, c.y1);
      kept.push_back(c);
    }
  auto frame = render_light_field(renderer, settings, 0, options);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_EQ(frame->views.size(), kept.size());
  const auto& optics = frame->description.optics;
  const double fx_px = optics.lens_to_sensor_mm / (optics.pixel_pitch_um * 1e-3);
  const double q = 1 / optics.focus_distance_m;
  const double radius_m = 8.0 / 2.0 / 2 * 1e-3;
  const double epr = frame->truth["electrons_per_unit_reflectance"];
  const double dn_per_reflectance = epr * (4095.0 - 64) / 20000;
  const bool hex = std::string(grid) == "hex";
  double worst = 0;
  for (size_t k = 0; k < kept.size(); ++k)
    for (int parity = 0; parity < 2; ++parity)
      for (int x = 0; x < width; ++x) {
        // Where the lattice puts this pixel (hex: odd rows half a pixel to the right),
        // from the optical axis; every row of a parity sees the same.
        const double x_px = x + (hex && parity ? 0.5 : 0.0) - optics.principal_point_px[0];
        const double truth = edge_view_truth(x_px, fx_px, z_m, q, edge_x_m, kept[k], radius_m);
        for (int y = parity; y < height; y += 2) {
          const double rendered = (frame->views[k].at<uint16_t>(y, x) - 64) / dn_per_reflectance;
          worst = std::max(worst, std::fabs(rendered - truth) / 0.7);
        }
      }
  // The brute-force cell grid is good to ~1e-4; the DN rounding is 0.5 / (0.7 x DN per
  // reflectance) = 2e-4 of the contrast.
  EXPECT_LT(worst, 1.5e-3) << grid << " " << views << "x" << views;
}

TEST(LightFieldRender, EdgeViewsMatchTheCellIntegralOnASquareLattice) {
  check_edge_views("square", 5);
}

TEST(LightFieldRender, EdgeViewsMatchTheCellIntegralOnAHexagonalLattice) {
  check_edge_views("hex", 4);
}

TEST(LightFieldRender, AreaWeightedViewsAreTheThinLensIntegral) {
  // Textures, edges, corners and two depths: every path of the integrator.
  json scene = {{"illuminance_lux", 1000},
                {"background_reflectance", 0.18},
                {"targets",
                 {{{"type", "texture"},
                   {"size_m", {0.03, 0.03}},
                   {"feature_m", 0.0012},
                   {"seed", 5},
                   {"pose", {{"position_m", {-0.012, 0.0, 0.7}}}}},
                  {{"type", "slanted_edge"},
                   {"size_m", {0.03, 0.03}},
                   {"angle_deg", 5},
                   {"pose", {{"position_m", {0.016, 0.002, 1.3}}}}}}}};
  Renderer renderer = testing::make_renderer(lightfield_camera(64, 40, 5, "none"), scene);
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 2.0;
  settings.focus_position = 65;
  RenderOptions options;
  options.noise = false;
  auto cells = optics::aperture_cells(5, 5);
  std::vector<ApertureRegion> regions;
  std::vector<double> shares;
  for (const auto& c : *cells)
    if (c.area_share > 0) {
      regions.emplace_back(c.x0, c.x1, c.y0, c.y1);
      shares.push_back(c.area_share);
    }
  auto lf = renderer.integrate_light_field(settings, 0, options, {&regions, 5, nullptr});
  ASSERT_TRUE(lf.ok()) << lf.error().message;
  auto thin = renderer.integrate_scene(settings, 0, options);
  ASSERT_TRUE(thin.ok());
  const int n = static_cast<int>(regions.size());
  std::vector<double> differences;
  int exact = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 64; ++x) {
      double sum = 0;
      for (int k = 0; k < n; ++k)
        sum += shares[static_cast<size_t>(k)] * lf->values.at<float>(y, x * n + k);
      differences.push_back(std::fabs(sum - thin->reflectance.at<float>(y, x)));
      exact += differences.back() < 1e-5;
    }
  std::sort(differences.begin(), differences.end());
  // Flat and edge pixels agree to rounding; textures (the cells' cubature against the
  // disk's) and sampled corners (random samples, both) to the rules' and the samples'
  // own error, which averages out over pixels.
  double mean = 0;
  for (double d : differences) mean += d / differences.size();
  EXPECT_GT(exact, 40 * 64 / 4);
  EXPECT_LT(differences[differences.size() * 99 / 100], 0.02) << "mean " << mean;
  EXPECT_LT(mean, 2e-3);
}

TEST(LightFieldRender, LensletImageHoldsTheViewsBehindEachMicrolens) {
  for (const char* grid : {"square", "hex"}) {
    const int views = std::string(grid) == "hex" ? 4 : 5;
    json camera = lightfield_camera(16, 16, views, grid);
    camera["lightfield"]["lenslet_margin_px"] = 3;
    Renderer renderer = testing::make_renderer(camera, edge_scene(0.6, 0.0002));
    RenderOptions options;
    options.noise = false;
    RenderSettings settings = renderer.default_settings();
    settings.f_number = 2.8;  // the light side well below the full well
    auto frame = render_light_field(renderer, settings, 0, options);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    auto cells = optics::aperture_cells(views, views);
    const int row_pitch =
        std::string(grid) == "hex" ? static_cast<int>(std::ceil(views * 0.8660254)) : views;
    ASSERT_EQ(frame->lenslet.cols,
              2 * 3 + 16 * views + (std::string(grid) == "hex" ? views / 2 : 0));
    ASSERT_EQ(frame->lenslet.rows, 2 * 3 + 15 * row_pitch + views);
    size_t k = 0;
    for (const auto& c : *cells) {
      if (c.area_share <= 0) continue;
      for (int l = 0; l < 16; ++l)
        for (int m = 0; m < 16; ++m) {
          // The block of microlens (m, l), mirrored: cell (i, j) at (U-1-i, U-1-j).
          const int bx = 3 + m * views + (l % 2) * (std::string(grid) == "hex" ? views / 2 : 0);
          const int by = 3 + l * row_pitch;
          const int px = bx + views - 1 - c.u_index, py = by + views - 1 - c.v_index;
          const double white = frame->white.at<uint16_t>(py, px) - 64.0;
          const double view = frame->views[k].at<uint16_t>(l, m) - 64.0;
          const double raw = frame->lenslet.at<uint16_t>(py, px) - 64.0;
          // Pixels two rows of a hexagonal grid share take light from both: skip them.
          const bool shared = white > 0.8 * 4031 * c.lit_share + 1;
          if (shared) continue;
          EXPECT_NEAR(white, 0.8 * 4031 * c.lit_share, 0.5);
          EXPECT_NEAR(raw, c.lit_share * view, 0.5 + c.lit_share * 0.5) << grid;
        }
      ++k;
    }
  }
}

TEST(LightFieldRender, DepthTruthIsTheChiefRaysHit) {
  // A plane tilted about y: its depth along each pixel centre's chief ray, written out.
  json scene = {
      {"illuminance_lux", 1000},
      {"background_reflectance", 0.18},
      {"targets",
       {{{"type", "uniform"},
         {"size_m", {0.02, 0.02}},
         {"pose", {{"position_m", {0.0, 0.0, 0.9}}, {"rotation_deg", {0.0, 30.0, 0.0}}}}}}}};
  Renderer renderer = testing::make_renderer(lightfield_camera(64, 48, 3, "none"), scene);
  RenderOptions options;
  options.noise = false;
  auto frame = render_light_field(renderer, renderer.default_settings(), 0, options);
  ASSERT_TRUE(frame.ok());
  const auto& o = frame->description.optics;
  const double fx = o.lens_to_sensor_mm / (o.pixel_pitch_um * 1e-3);
  // The plane through (0, 0, 0.9) with normal R (0, 0, 1), R a rotation of 30 deg about y.
  const double nx = std::sin(M_PI / 6), nz = std::cos(M_PI / 6);
  int on_target = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      const double mx = (x - o.principal_point_px[0]) / fx;
      const double z = nz * 0.9 / (nx * mx + nz);
      const double truth = frame->depth_m.at<float>(y, x);
      if (truth == 0) continue;  // off the target (its 2 cm square)
      ++on_target;
      EXPECT_NEAR(truth, z, 1e-6 * z);
    }
  EXPECT_GT(on_target, 500);
}

TEST(LightFieldRender, SpecRefusesWhatCannotBeRendered) {
  struct Case {
    json lightfield;
    const char* expect;
  };
  const Case cases[] = {
      {{{"views", {9, 7}}, {"microlens_grid", "square"}}, "must be equal"},
      {{{"views", {9, 9}}, {"microlens_grid", "hex"}}, "even number"},
      {{{"views", {17, 17}}}, "[1, 16]"},
      {{{"views", {9, 9}}, {"microlens_grid", "round"}}, "none, square, hex"},
      {{{"microlens_grid", "square"}}, "views is required"},
  };
  for (const Case& c : cases) {
    json camera = testing::pinhole_camera_json(32, 32);
    camera["lightfield"] = c.lightfield;
    auto spec = parse_camera_spec(camera);
    ASSERT_FALSE(spec.ok()) << c.lightfield.dump();
    EXPECT_NE(spec.error().message.find(c.expect), std::string::npos) << spec.error().message;
  }
  json distorted = testing::pinhole_camera_json(32, 32);
  distorted["lens"]["model"] = "LENSMODEL_OPENCV4";
  distorted["lens"]["distortion"] = {-0.05, 0.01, 0, 0};
  distorted["lightfield"] = {{"views", {5, 5}}};
  auto spec = parse_camera_spec(distorted);
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.error().code, ErrorCode::kUnsupported);
  json colour = testing::colour_camera_json(32, 32);
  colour["lightfield"] = {{"views", {5, 5}}};
  EXPECT_FALSE(parse_camera_spec(colour).ok());
  // Without a lightfield block there is no light field to render.
  Renderer plain = testing::make_renderer(testing::pinhole_camera_json(32, 32), edge_scene(1, 0));
  auto frame = render_light_field(plain, plain.default_settings(), 0, RenderOptions{});
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace camlab::mock
