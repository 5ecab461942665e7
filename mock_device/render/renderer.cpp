#include "mock_device/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "mock_device/render/channel_optics.h"
#include "mock_device/render/frame_truth.h"
#include "mock_device/render/pixel_quadrature.h"
#include "mock_device/render/radiance_integrator.h"
#include "mock_device/render/sampling.h"
#include "mock_device/render/sensor_model.h"
#include "optics/optics.h"

namespace camlab::mock {

namespace {

// The reflectance image with each pixel scaled by its channel's `ratio` (a shared,
// unchanged image when every ratio is 1, as for a monochrome sensor).
cv::Mat scaled_by_channel(const cv::Mat& reflectance, const SensorSpec& sensor,
                          const std::array<double, 3>& ratio) {
  if (!sensor.is_colour() || (ratio[0] == 1 && ratio[1] == 1 && ratio[2] == 1)) return reflectance;
  cv::Mat out(reflectance.size(), CV_32F);
  for (int y = 0; y < out.rows; ++y) {
    const float* in = reflectance.ptr<float>(y);
    float* row = out.ptr<float>(y);
    for (int x = 0; x < out.cols; ++x)
      row[x] = static_cast<float>(in[x] * ratio[static_cast<size_t>(sensor.channel_at(x, y))]);
  }
  return out;
}

// The lens's baseline blur over each of the n values per pixel (n planes interleaved in
// one image: a light field's cells).
void blur_each_value(cv::Mat& values, int n, double sigma_px) {
  if (n == 1) {
    cv::GaussianBlur(values, values, cv::Size(), sigma_px, sigma_px, cv::BORDER_REFLECT);
    return;
  }
  cv::Mat interleaved = values.reshape(n);  // width x n channels
  std::vector<cv::Mat> planes;
  for (int k = 0; k < n; ++k) {
    cv::Mat plane;
    cv::extractChannel(interleaved, plane, k);
    cv::GaussianBlur(plane, plane, cv::Size(), sigma_px, sigma_px, cv::BORDER_REFLECT);
    cv::insertChannel(plane, interleaved, k);
  }
}

std::string range_text(double lo, double hi, const char* unit) {
  char text[96];
  std::snprintf(text, sizeof text, "[%g, %g] %s", lo, hi, unit);
  return text;
}

}  // namespace

Result<Renderer> Renderer::create(CameraSpec camera, SceneSpec scene) {
  Renderer r;
  r.camera_ = std::move(camera);
  r.scene_ = std::move(scene);
  auto rays =
      ChiefRayTable::create(r.camera_.lens.model, intrinsics_at(r.camera_, r.camera_.lens.focal_mm),
                            r.camera_.sensor.width_px, r.camera_.sensor.height_px);
  if (!rays) return rays.error();
  if (rays->invalid_fraction() > 0.5)
    return make_error("projection_failed",
                      "the lens model cannot unproject " +
                          std::to_string(static_cast<int>(rays->invalid_fraction() * 100)) +
                          "% of the imager; check lens.distortion");
  r.reference_rays_ = std::make_shared<const ChiefRayTable>(std::move(*rays));
  for (const auto& target : r.scene_.targets) {
    r.textures_.push_back(make_texture(target));
    std::shared_ptr<const CharucoPattern> pattern;
    if (target.type == TargetType::kCharuco) CAMLAB_ASSIGN(pattern, CharucoPattern::create(target));
    r.charuco_patterns_.push_back(std::move(pattern));
  }
  return r;
}

Status Renderer::set_target_pose(const std::string& target, int view, const RtCamTarget& pose) {
  if (view < 0 || view >= scene_.view_count)
    return make_error("out_of_range", "view " + std::to_string(view) + " is not in [0, " +
                                          std::to_string(scene_.view_count - 1) + "]");
  if (!(pose[5] > 0) ||
      !std::all_of(pose.begin(), pose.end(), [](double v) { return std::isfinite(v); }))
    return make_error("out_of_range",
                      "the target origin must be finite and in front of the camera (z > 0)");
  for (TargetSpec& t : scene_.targets) {
    if (t.name != target) continue;
    // A single-pose target is the same in every view: it moves in all of them.
    t.poses[t.poses.size() == 1 ? 0 : static_cast<size_t>(view)] = pose;
    integral_cache_.clear();
    return {};
  }
  std::string names;
  for (const TargetSpec& t : scene_.targets) names += (names.empty() ? "" : ", ") + t.name;
  return make_error("not_found", "the scene has no target '" + target.substr(0, 60) +
                                     "' (it has: " + names + ")");
}

RenderSettings Renderer::default_settings() const {
  const ControlsSpec& c = camera_.controls;
  RenderSettings s;
  s.exposure_us = c.exposure_time_absolute.default_value * 100.0;
  s.gain = static_cast<double>(c.gain.default_value) / c.gain_unity;
  s.f_number = camera_.lens.iris.f_numbers[c.iris_absolute.default_value];
  s.focus_position = c.focus_absolute.default_value;
  return s;
}

Status Renderer::validate(const RenderSettings& s) const {
  const ControlsSpec& c = camera_.controls;
  const double exposure_min = c.exposure_time_absolute.min * 100.0;
  const double exposure_max = c.exposure_time_absolute.max * 100.0;
  if (!(s.exposure_us >= exposure_min && s.exposure_us <= exposure_max))
    return make_error("out_of_range", "exposure_us = " + std::to_string(s.exposure_us) +
                                          " is outside the camera's " +
                                          range_text(exposure_min, exposure_max, "us") +
                                          " (capped by the frame interval)");
  const double gain_min = static_cast<double>(c.gain.min) / c.gain_unity;
  const double gain_max = static_cast<double>(c.gain.max) / c.gain_unity;
  if (!(s.gain >= gain_min && s.gain <= gain_max))
    return make_error("out_of_range", "gain = " + std::to_string(s.gain) + " is outside " +
                                          range_text(gain_min, gain_max, "x (linear)"));
  if (!(s.f_number >= camera_.lens.f_number_min && s.f_number <= camera_.lens.f_number_max))
    return make_error(
        "out_of_range",
        "f_number = " + std::to_string(s.f_number) + " is outside the lens's " +
            range_text(camera_.lens.f_number_min, camera_.lens.f_number_max, "(f-number)"));
  if (s.focus_position < camera_.lens.focus.position_min ||
      s.focus_position > camera_.lens.focus.position_max)
    return make_error("out_of_range", "focus_position = " + std::to_string(s.focus_position) +
                                          " is outside " +
                                          range_text(camera_.lens.focus.position_min,
                                                     camera_.lens.focus.position_max, "(steps)"));
  return {};
}

const ChiefRayTable& Renderer::rays_for(int focus_position, int threads) {
  if (focus_position == 0 || camera_.lens.focus.extension_mm_per_step == 0) return *reference_rays_;
  for (const auto& [position, table] : rays_by_focus_)
    if (position == focus_position) return *table;
  // Bounded (a table is 2.5 MB at 640x480, 8 MB at 1280x800); a new one costs a resampling
  // of the reference, a few ms, so a sweep need not keep them all.
  if (rays_by_focus_.size() >= kRayTableCacheSize) rays_by_focus_.erase(rays_by_focus_.begin());
  const double lens_to_sensor_mm =
      camera_.lens.focal_mm + focus_position * camera_.lens.focus.extension_mm_per_step;
  rays_by_focus_.emplace_back(focus_position,
                              std::make_shared<const ChiefRayTable>(reference_rays_->rescaled(
                                  lens_to_sensor_mm / camera_.lens.focal_mm, threads)));
  return *rays_by_focus_.back().second;
}

cv::Mat Renderer::integrate(const IntegratorSetup& setup, RenderStats* stats) const {
  const double sigma_px = camera_.lens.baseline_blur_sigma_px;
  const int n = values_per_pixel(setup);
  IntegratorStats counts;
  cv::Mat result;
  if (sigma_px <= 0 || setup.cfa.empty()) {
    result = integrate_reflectance(setup, &counts);
    if (sigma_px > 0) blur_each_value(result, n, sigma_px);
  } else {
    // The baseline blur spreads each colour over its neighbours, which a mosaic does not
    // hold: integrate R, G and B at every pixel (three times the cost), blur each plane
    // and keep each pixel's own colour.
    std::array<cv::Mat, 3> planes;
    for (int c = 0; c < 3; ++c) {
      IntegratorSetup one = setup;
      one.cfa.clear();
      one.channel = c;
      IntegratorStats plane_counts;
      planes[static_cast<size_t>(c)] = integrate_reflectance(one, &plane_counts);
      counts += plane_counts;
      blur_each_value(planes[static_cast<size_t>(c)], n, sigma_px);
    }
    result = cv::Mat(planes[0].size(), CV_32F);
    for (int y = 0; y < result.rows; ++y)
      for (int x = 0; x < result.cols; ++x)
        result.at<float>(y, x) =
            planes[static_cast<size_t>(camera_.sensor.channel_at(x / n, y))].at<float>(y, x);
  }
  const double pixels = counts.flat_pixels + counts.edge_pixels + counts.edge_sampled_pixels +
                        counts.smooth_pixels + counts.sampled_pixels;
  if (setup.adaptive && pixels > 0) {
    stats->flat_share = counts.flat_pixels / pixels;
    stats->edge_share = (counts.edge_pixels + counts.edge_sampled_pixels) / pixels;
    stats->smooth_share = counts.smooth_pixels / pixels;
    stats->sampled_share = counts.sampled_pixels / pixels;
    stats->mean_samples_per_pixel = counts.evaluations / pixels;
  }
  return result;
}

const SceneIntegral* Renderer::cached_integral(const IntegrationKey& key) const {
  for (const auto& [k, integral] : integral_cache_)
    if (k == key) return &integral;  // its image is shared, never written after insertion
  return nullptr;
}

void Renderer::remember_integral(const IntegrationKey& key, const SceneIntegral& integral) {
  // Bounded: a long focus sweep must not hold every frame's integral in memory.
  if (integral_cache_.size() >= kReflectanceCacheSize)
    integral_cache_.erase(integral_cache_.begin());
  integral_cache_.emplace_back(key, integral);
}

struct Renderer::FramePlan {
  RenderSettings settings;
  int view = 0;
  double lens_to_sensor_mm = 0;
  double focus_mm = 0;
  std::vector<TargetSurface> surfaces;  // the targets at this view
  IntegratorSetup setup;                // without `surfaces`: set where it is used
  IntegrationKey key{};
  std::array<ChannelTruthInputs, 3> channels{};
  RenderStats stats;
};

Result<Renderer::FramePlan> Renderer::plan_frame(const RenderSettings& settings, int view,
                                                 const RenderOptions& options) {
  if (Status ok = validate(settings); !ok) return ok.error();
  if (view < 0 || view >= scene_.view_count)
    return make_error("out_of_range", "view " + std::to_string(view) + " is not in 0.." +
                                          std::to_string(scene_.view_count - 1));
  FramePlan plan;
  plan.settings = settings;
  plan.view = view;
  const LensSpec& lens = camera_.lens;
  plan.lens_to_sensor_mm =
      lens.focal_mm + settings.focus_position * lens.focus.extension_mm_per_step;
  auto focus_mm = optics::focus_distance_mm(lens.focal_mm, plan.lens_to_sensor_mm);
  if (!focus_mm) return focus_mm.error();
  plan.focus_mm = *focus_mm;

  std::vector<TargetSurface>& surfaces = plan.surfaces;
  surfaces.reserve(scene_.targets.size());
  for (size_t i = 0; i < scene_.targets.size(); ++i)
    surfaces.emplace_back(scene_.targets[i], scene_.pose(scene_.targets[i], view), textures_[i],
                          charuco_patterns_[i]);

  // Lens samples for the largest predicted CoC a channel sees (docs/BENCHMARKS.md).
  auto lens_grid_for = [&](double max_coc_px) {
    if (options.aperture_samples > 0)
      return std::max(1, static_cast<int>(std::lround(std::sqrt(options.aperture_samples))));
    if (options.aperture_samples < 0) return lens_grid_for_coc(max_coc_px);
    return 0;
  };

  RenderStats& stats = plan.stats;
  IntegratorSetup& setup = plan.setup;
  setup.threads =
      options.threads > 0 ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  setup.rays = &rays_for(settings.focus_position, setup.threads);
  setup.aperture_radius_m = lens.focal_mm / settings.f_number / 2 * 1e-3;
  setup.pixel_grid =
      options.pixel_samples > 0
          ? std::max(1, static_cast<int>(std::lround(std::sqrt(options.pixel_samples))))
          : 4;
  const SensorSpec& sensor = camera_.sensor;
  // A tilted or curved focus surface: each pixel focuses as the lens would at z_s - delta,
  // so the blur a channel can give spans the surface's offsets over the imager.
  // The surface's offsets that bound the blur: none without one, else its extremes.
  std::vector<double> deltas_mm = {0};
  setup.field_focus = make_field_focus(camera_, plan.lens_to_sensor_mm);
  if (setup.field_focus) {
    deltas_mm.resize(2);
    setup.field_focus->offset_range_mm(0, sensor.width_px, 0, sensor.height_px, &deltas_mm[0],
                                       &deltas_mm[1]);
  }
  // The largest blur (px) a channel gives any target.
  auto largest_coc_px = [&](int channel) -> Result<double> {
    double largest = 0;
    if (!setup.field_focus && channel == kGrey) {
      for (const auto& surface : surfaces)
        largest =
            std::max(largest, predicted_coc(camera_, surface, settings.f_number, *focus_mm).max_px);
      return largest;
    }
    for (double delta_mm : deltas_mm) {
      auto optics =
          channel_optics(camera_, channel, settings.f_number, plan.lens_to_sensor_mm - delta_mm);
      if (!optics) return optics.error();
      for (const auto& surface : surfaces)
        largest = std::max(largest, predicted_coc(*optics, sensor.pixel_pitch_um, surface).max_px);
    }
    return largest;
  };
  std::array<int, 3> lens_grids = {0, 0, 0};
  if (!sensor.is_colour()) {
    auto largest = largest_coc_px(kGrey);
    if (!largest) return largest.error();
    stats.max_coc_px = *largest;
    ChannelSetup& grey = setup.channels[kGrey];
    grey.focal_mm = lens.focal_mm;
    grey.background_reflectance = scene_.background.grey;
    grey.focus_distance_m = *focus_mm * 1e-3;
    grey.lens_grid = lens_grid_for(stats.max_coc_px);
    lens_grids[0] = grey.lens_grid;
    stats.aperture_samples = grey.lens_grid * grey.lens_grid;
    stats.pixel_samples =
        grey.lens_grid > 0 ? stats.aperture_samples : setup.pixel_grid * setup.pixel_grid;
  } else {
    // Each pixel sees its own colour, through its channel's own focus.
    setup.cfa = sensor.cfa;
    for (int c = 0; c < 3; ++c) {
      auto optics = channel_optics(camera_, c, settings.f_number, plan.lens_to_sensor_mm);
      if (!optics) return optics.error();
      auto largest = largest_coc_px(c);
      if (!largest) return largest.error();
      const double max_coc_px = *largest;
      stats.max_coc_px = std::max(stats.max_coc_px, max_coc_px);
      ChannelSetup& channel = setup.channels[static_cast<size_t>(c)];
      channel.focal_mm = optics->focal_mm;
      channel.ray_scale = 1 / channel_image_scale(camera_, c);
      channel.background_reflectance = scene_.background.rgb[static_cast<size_t>(c)];
      channel.focus_distance_m = optics->focus_distance_mm * 1e-3;
      channel.lens_grid = lens_grid_for(max_coc_px);
      lens_grids[static_cast<size_t>(c)] = channel.lens_grid;
      const int samples = channel.lens_grid * channel.lens_grid;
      stats.aperture_samples = std::max(stats.aperture_samples, samples);
      stats.pixel_samples = std::max(stats.pixel_samples,
                                     samples > 0 ? samples : setup.pixel_grid * setup.pixel_grid);
      ChannelTruthInputs& truth = plan.channels[static_cast<size_t>(c)];
      truth.optics = *optics;
      truth.quantum_efficiency = sensor.quantum_efficiency_rgb[static_cast<size_t>(c)];
      truth.aperture_samples = samples;
    }
  }
  // The scene integral depends on the seed but not on the frame: repeated frames of one
  // setting differ by sensor noise only, as a static scene's frames do (a frame-varying
  // sampling pattern would add rendering noise to photon-transfer measurements).
  stats.mean_samples_per_pixel = stats.pixel_samples;
  setup.seed = mix_seed(options.seed, 1);
  // Explicit counts (either) take the uniform path: every pixel those samples.
  setup.adaptive = options.aperture_samples < 0 && options.pixel_samples < 0;
  plan.key = IntegrationKey{view,          settings.focus_position, settings.f_number,
                            lens_grids,    setup.pixel_grid,        setup.seed,
                            setup.adaptive};
  return plan;
}

cv::Mat Renderer::scene_integral(const FramePlan& plan, RenderStats* stats) {
  if (const SceneIntegral* cached = cached_integral(plan.key)) {
    stats->cached = true;
    stats->mean_samples_per_pixel = cached->stats.mean_samples_per_pixel;
    stats->flat_share = cached->stats.flat_share;
    stats->edge_share = cached->stats.edge_share;
    stats->smooth_share = cached->stats.smooth_share;
    stats->sampled_share = cached->stats.sampled_share;
    return cached->reflectance;
  }
  stats->cached = false;
  IntegratorSetup setup = plan.setup;
  setup.surfaces = &plan.surfaces;
  SceneIntegral integral;
  integral.stats = *stats;
  integral.reflectance = integrate(setup, &integral.stats);
  *stats = integral.stats;
  remember_integral(plan.key, integral);
  return integral.reflectance;
}

Result<SceneIntegral> Renderer::integrate_scene(const RenderSettings& settings, int view,
                                                const RenderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto plan = plan_frame(settings, view, options);
  if (!plan) return plan.error();
  SceneIntegral out;
  out.stats = plan->stats;
  out.reflectance = scene_integral(*plan, &out.stats);
  out.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

void Renderer::describe_frame(const FramePlan& plan, const RenderStats& stats,
                              const RenderOptions& options, double electrons_per_reflectance,
                              nlohmann::json* settings_json, nlohmann::json* truth_json) const {
  const RenderSettings& settings = plan.settings;
  const SensorSpec& sensor = camera_.sensor;
  // A colour pixel collects its channel's QE where the sensor model counts the grey QE.
  std::array<ChannelTruthInputs, 3> channels = plan.channels;
  for (int c = 0; c < 3 && sensor.is_colour(); ++c)
    channels[static_cast<size_t>(c)].electrons_per_unit_reflectance =
        electrons_per_reflectance * sensor.quantum_efficiency_rgb[static_cast<size_t>(c)] /
        sensor.quantum_efficiency;
  TruthInputs truth;
  truth.camera = &camera_;
  truth.scene = &scene_;
  truth.surfaces = &plan.surfaces;
  truth.view = plan.view;
  truth.intrinsics = intrinsics_at(camera_, plan.lens_to_sensor_mm);
  truth.f_number = settings.f_number;
  truth.focus_distance_mm = plan.focus_mm;
  truth.lens_to_sensor_mm = plan.lens_to_sensor_mm;
  truth.electrons_per_unit_reflectance = electrons_per_reflectance;
  truth.gain = settings.gain;
  truth.channels = channels;
  *truth_json = make_frame_truth(truth);
  (*truth_json)["render"] = {{"aperture_samples", stats.aperture_samples},
                             {"samples_per_pixel", stats.pixel_samples},
                             {"mean_samples_per_pixel", stats.mean_samples_per_pixel},
                             {"max_coc_px", stats.max_coc_px},
                             {"noise", options.noise},
                             {"integral_reused", stats.cached},
                             {"seed", options.seed},
                             {"frame_number", options.frame_number}};
  if (plan.setup.adaptive)
    (*truth_json)["render"]["pixel_paths"] = {{"flat", stats.flat_share},
                                              {"edge", stats.edge_share},
                                              {"smooth", stats.smooth_share},
                                              {"sampled", stats.sampled_share}};
  const ControlsSpec& c = camera_.controls;
  *settings_json = {
      {"exposure_us", settings.exposure_us},
      {"exposure_time_absolute", settings.exposure_us / 100.0},
      {"gain", settings.gain},
      {"gain_control", settings.gain * c.gain_unity},
      {"f_number", settings.f_number},
      {"focus_position", settings.focus_position},
      {"focus_distance_m", plan.focus_mm * 1e-3},
      {"lens_to_sensor_mm", plan.lens_to_sensor_mm},
  };
}

Result<RenderedFrame> Renderer::render(const RenderSettings& settings, int view,
                                       const RenderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto planned = plan_frame(settings, view, options);
  if (!planned) return planned.error();
  const FramePlan& plan = *planned;
  RenderStats stats = plan.stats;
  cv::Mat reflectance = scene_integral(plan, &stats);

  const SensorSpec& sensor = camera_.sensor;
  const double electrons_per_reflectance =
      electrons_per_unit_reflectance(camera_, scene_.illuminance_lux, settings.exposure_us,
                                     settings.f_number, plan.lens_to_sensor_mm);
  // A colour pixel collects its channel's QE where the sensor model counts the grey QE:
  // its reflectance is scaled by the ratio.
  std::array<double, 3> qe_ratio = {1, 1, 1};
  for (int c = 0; c < 3 && sensor.is_colour(); ++c)
    qe_ratio[static_cast<size_t>(c)] =
        sensor.quantum_efficiency_rgb[static_cast<size_t>(c)] / sensor.quantum_efficiency;
  RenderedFrame frame;
  frame.image = expose(scaled_by_channel(reflectance, sensor, qe_ratio), camera_,
                       electrons_per_reflectance, settings.gain, options.noise,
                       mix_seed(options.seed, options.frame_number * 2 + 2), plan.setup.threads);
  describe_frame(plan, stats, options, electrons_per_reflectance, &frame.settings, &frame.truth);
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  frame.stats = stats;
  return frame;
}

Result<LightFieldIntegral> Renderer::integrate_light_field(const RenderSettings& settings, int view,
                                                           const RenderOptions& options,
                                                           const LightFieldCells& cells) {
  const auto start = std::chrono::steady_clock::now();
  if (!cells.regions || cells.regions->empty())
    return make_error("invalid_argument", "a light field needs at least one aperture cell");
  auto planned = plan_frame(settings, view, options);
  if (!planned) return planned.error();
  FramePlan& plan = *planned;
  IntegratorSetup setup = plan.setup;
  setup.surfaces = &plan.surfaces;
  setup.cells = cells.regions;
  setup.cells_per_side = std::max(1, cells.per_side);
  if (cells.rays) setup.rays = cells.rays;
  LightFieldIntegral out;
  out.stats = plan.stats;
  out.values = integrate(setup, &out.stats);

  // The truth's depth: the first surface along each pixel centre's chief ray.
  const ChiefRayTable& rays = *setup.rays;
  out.depth_m = cv::Mat(rays.height_px(), rays.width_px(), CV_32F, cv::Scalar(0));
  for (int y = 0; y < rays.height_px(); ++y)
    for (int x = 0; x < rays.width_px(); ++x) {
      if (!pixel_valid(rays, x, y)) continue;
      const double o[3] = {0, 0, 0};
      double d[3] = {0, 0, 1};
      PixelCorners(rays, x, y).at(0.5, 0.5, &d[0], &d[1]);
      double nearest = 0;
      for (const TargetSurface& surface : plan.surfaces) {
        double unused;
        const double lambda = surface.intersect(o, d, kGrey, &unused);
        if (lambda > 0 && (nearest == 0 || lambda < nearest)) nearest = lambda;
      }
      out.depth_m.at<float>(y, x) = static_cast<float>(nearest);  // d_z = 1: lambda is z
    }

  out.electrons_per_unit_reflectance =
      electrons_per_unit_reflectance(camera_, scene_.illuminance_lux, settings.exposure_us,
                                     settings.f_number, plan.lens_to_sensor_mm);
  describe_frame(plan, out.stats, options, out.electrons_per_unit_reflectance, &out.settings,
                 &out.truth);
  out.stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace camlab::mock
