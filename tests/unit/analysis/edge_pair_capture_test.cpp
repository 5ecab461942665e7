// The joint fit of two close parallel edges on the virtual camera: a single dark bar
// 2 mm wide (7.6 px) at 0.35 m, tilted 4 degrees, defocused to 3.8-15.2 px at f/8-f/2 so
// that each edge's window holds the other's blur; its diameter against the renderer's
// predicted CoC (the truth), within the limit plus the frame's own noise.
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/edge/edge_measure.h"
#include "capture_fixture.h"

namespace camlab::analysis {
namespace {

constexpr double kBarWidth_m = 0.002, kTargetSize_m = 0.04, kDistance_m = 0.35, kRoll_deg = 4.0;

nlohmann::json camera_json() {
  return {
      {"name", "bar test"},
      {"sensor",
       {{"width_px", 192},
        {"height_px", 192},
        {"pixel_pitch_um", 6.0},
        {"bit_depth", 12},
        {"black_level_dn", 64},
        {"full_well_e", 20000},
        {"read_noise_e", 2.0},
        {"quantum_efficiency", 0.6}}},
      {"lens",
       {{"focal_mm", 8.0},
        {"model", "LENSMODEL_PINHOLE"},
        {"f_number_min", 1.4},
        {"f_number_max", 22.0},
        {"focus",
         {{"position_min", 0}, {"position_max", 2000}, {"extension_mm_per_step", 0.001}}}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 100}}}}}};
}

nlohmann::json bar_scene_json() {
  return {
      {"illuminance_lux", 1000},
      {"background_reflectance", 0.8},
      {"targets",
       {{{"type", "bars"},
         {"name", "bar"},
         {"size_m", {kTargetSize_m, kTargetSize_m}},
         {"bar_width_m", kBarWidth_m},
         {"bar_count", 1},
         {"dark_reflectance", 0.1},
         {"light_reflectance", 0.8},
         {"pose",
          {{"position_m", {0.0, 0.0, kDistance_m}}, {"rotation_deg", {0.0, 0.0, kRoll_deg}}}}}}}};
}

// The bar's two edges in px through the frame's truth (pinhole intrinsics and the
// target's pose): u = -+w/2 in the target frame, 30 mm long.
std::vector<EdgeSegment> bar_edges(const nlohmann::json& truth) {
  const auto& in = truth["intrinsics"];
  const auto& rt = truth["targets"][0]["rt_cam_target"];
  const double angle =
      std::hypot(rt[0].get<double>(), std::hypot(rt[1].get<double>(), rt[2].get<double>()));
  const double c = std::cos(angle), s = std::sin(angle) * (rt[2].get<double>() >= 0 ? 1 : -1);
  auto px = [&](double u, double v) {  // rotation about the camera's z axis only
    const double x = c * u - s * v + rt[3].get<double>(), y = s * u + c * v + rt[4].get<double>();
    const double z = rt[5].get<double>();
    return std::array<double, 2>{in[0].get<double>() * x / z + in[2].get<double>(),
                                 in[1].get<double>() * y / z + in[3].get<double>()};
  };
  const double scale = in[0].get<double>() / rt[5].get<double>();  // px per m on the target
  std::vector<EdgeSegment> edges;
  for (double u : {-0.5 * kBarWidth_m, 0.5 * kBarWidth_m}) {
    const auto a = px(u, -0.015), b = px(u, 0.015);
    edges.push_back({u < 0 ? "left" : "right", a[0], a[1], b[0], b[1],
                     scale * 0.5 * (kTargetSize_m - kBarWidth_m)});
  }
  return edges;
}

TEST(EdgePairCapture, BarOnTheVirtualCameraMeasuredJointly) {
  auto renderer = testing::make_renderer(camera_json(), bar_scene_json());
  for (double n : {2.0, 4.0, 8.0}) {
    mock::RenderOptions ro;
    ro.aperture_samples = 256;  // the rendering's own sampling error well below the limit
    ro.seed = 11;
    const mock::RenderSettings settings{std::round(27.0 * (n / 2) * (n / 2)) * 100.0, 1.0, n, 0};
    auto frame = renderer.render(settings, 0, ro);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    const double truth_px = frame->truth["targets"][0]["coc_px"]["at_origin"].get<double>();
    cv::Mat signal;
    frame->image.convertTo(signal, CV_32F, 1.0, -64.0);
    const auto edges = bar_edges(frame->truth);
    ASSERT_NEAR(std::hypot(edges[1].start_x_px - edges[0].start_x_px,
                           edges[1].start_y_px - edges[0].start_y_px),
                7.62, 0.05);
    for (const EdgeSegment& e : edges) {
      auto m = measure_edge(signal, e, edges, {});
      ASSERT_TRUE(m.ok());
      ASSERT_EQ(m->status, kEdgeOk) << "f/" << n << " " << e.name << ": " << m->message;
      EXPECT_FALSE(m->joint_with.empty()) << "f/" << n;
      std::printf(
          "  f/%g %s: D %.4f +- %.4f px (truth %.4f, error %+.4f), joint with %s, separation %.3f "
          "px\n",
          n, e.name.c_str(), m->diameter_px, m->diameter_sigma_px, truth_px,
          m->diameter_px - truth_px, m->joint_with.c_str(), m->joint_separation_px);
      EXPECT_NEAR(m->diameter_px, truth_px,
                  std::max(0.05, 0.01 * truth_px) + 2 * m->diameter_sigma_px)
          << "f/" << n << " " << e.name;
    }
  }
}

}  // namespace
}  // namespace camlab::analysis
