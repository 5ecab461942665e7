// The virtual camera's physically based renderer.
//
// For every pixel it integrates the scene's radiance over the pixel's area and over the
// lens aperture, as the thin-lens recipe of docs/physics.md does: a sample point x' on the sensor
// defines the chief ray (through the lens centre, bent by the exact mrcal lens model),
// which meets the plane of focus at x'''; a sample point x'' on the aperture disk
// (diameter A = f / N) sends the ray x'' -> x''' into the scene. Stratified samples
// (concentric disk for the lens) are randomised per pixel, so the estimate is unbiased
// and its error averages out across pixels.
//
// Radiometry: targets are Lambertian (radiance = reflectance x illuminance / pi); sensor
// irradiance E = pi L / (4 N^2) (f / z_s)^2, the (f / z_s)^2 being the working-aperture
// loss when focused close; electrons = QE x photons (555 nm) over the pixel area and the
// exposure time. Then photon shot noise (Poisson), full-well clipping, read noise,
// conversion gain x analogue gain, black level, rounding and clipping to the bit depth.
//
// Only what the scene needs is modelled: each pixel takes the work what its own rays see
// needs (radiance_integrator.h: one value for a flat patch, a closed form for a straight
// edge, a cubature rule for a texture, samples for the rest at the count its own blur
// needs), no noise when the sensor spec has none.
//
// A Renderer is thread-compatible: render() may be called from one thread at a time; it
// uses std::thread internally for rows.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "mock_device/render/charuco_pattern.h"
#include "mock_device/render/chief_ray_table.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

struct IntegratorSetup;  // radiance_integrator.h
class ApertureRegion;    // aperture_region.h

// The settings a frame is rendered with, in physical units.
struct RenderSettings {
  double exposure_us = 10000;
  double gain = 1.0;  // linear analogue gain (1 = unity)
  double f_number = 4.0;
  int focus_position = 0;  // focus_absolute; 0 = infinity
};

struct RenderOptions {
  // Both -1: the automatic rule, each pixel what its own rays need (radiance_integrator.h).
  // Either set: every pixel takes these counts, tracing every target (the uniform path).
  int aperture_samples = -1;  // lens samples per pixel; -1 = from the predicted CoC
  int pixel_samples = -1;     // area samples per pixel when the lens is not sampled; -1 = 16
  bool noise = true;          // false renders the expected signal (still quantised)
  uint64_t seed = 1;
  uint64_t frame_number = 0;  // mixed into the noise seed: every frame has its own noise
  int threads = 0;            // 0 = hardware concurrency
};

struct RenderStats {
  // Lens and total samples per pixel: the counts every pixel takes with explicit counts;
  // with the automatic rule the most any pixel may take (the rule at the largest
  // predicted CoC). 0 lens samples = pinhole (lens not sampled).
  int aperture_samples = 0;
  int pixel_samples = 0;
  // Rays traced (or straight-edge coverages evaluated) per pixel, over the frame.
  double mean_samples_per_pixel = 0;
  // Where the automatic rule's work went, as shares of the pixels: one flat patch (one
  // value, exactly), one straight edge (exact coverage), one smooth pattern (a fixed
  // cubature rule), sampled at random. 0 with explicit counts.
  double flat_share = 0;
  double edge_share = 0;
  double smooth_share = 0;
  double sampled_share = 0;
  double max_coc_px = 0;  // largest predicted CoC over the visible targets
  double seconds = 0;
  bool cached = false;  // the scene integral was reused from an earlier frame
};

// The scene integral of one frame: mean reflectance per pixel, each pixel in its own
// channel, before the sensor (QE, noise, quantisation).
struct SceneIntegral {
  cv::Mat reflectance;  // CV_32F, height x width of the sensor
  RenderStats stats;
};

struct RenderedFrame {
  // CV_8UC1 (bit depth 8) or CV_16UC1: raw DN; for a colour sensor the raw Bayer mosaic
  // (each pixel its own colour, sensor.cfa).
  cv::Mat image;
  nlohmann::json settings;  // the settings in effect, with units in the keys
  nlohmann::json truth;     // ground truth (docs/virtual-camera.md)
  RenderStats stats;
};

// The sub-apertures a light field is integrated over (docs/virtual-camera.md, "Light
// fields").
struct LightFieldCells {
  const std::vector<ApertureRegion>* regions = nullptr;  // none empty; units of the radius
  int per_side = 1;  // cells per side of their grid (a cell's blur is the disk's over it)
  // The chief rays to integrate on instead of the camera's own at this focus (the rows of
  // a hexagonal microlens lattice); null: the camera's.
  const ChiefRayTable* rays = nullptr;
};

// A light field's scene integral and what a frame of it carries.
struct LightFieldIntegral {
  // CV_32F, height x (width x n): each pixel's mean reflectance through each of the n
  // cells, side by side, each pixel in its own channel.
  cv::Mat values;
  // CV_32F, height x width: the depth (m, along the axis) of the surface the chief ray
  // through each pixel's centre meets first; 0 where it meets none.
  cv::Mat depth_m;
  nlohmann::json settings;  // as render() gives them
  nlohmann::json truth;     // as render() gives it (the whole lens's CoC, poses, ...)
  double electrons_per_unit_reflectance = 0;
  RenderStats stats;
};

class Renderer {
 public:
  // What the (expensive) scene integral depends on; exposure, gain and noise do not
  // change it, so brackets and repeats reuse it.
  struct IntegrationKey {
    int view;
    int focus_position;
    double f_number;
    std::array<int, 3> lens_grids;  // grey (then 0, 0), or R, G, B
    int pixel_grid;
    uint64_t seed;
    bool adaptive;  // the automatic rule's paths, or uniform sampling
    bool operator==(const IntegrationKey&) const = default;
  };

  // Unprojects the lens once (about a second for a megapixel) and builds the textures.
  static Result<Renderer> create(CameraSpec camera, SceneSpec scene);

  // Checks the settings against the camera's ranges; renders view `view` of the scene.
  Result<RenderedFrame> render(const RenderSettings& settings, int view,
                               const RenderOptions& options);

  // The scene integral alone, as render() computes (and caches) it: what the sensor model
  // turns into DN. For measuring the renderer's speed and error without the sensor.
  Result<SceneIntegral> integrate_scene(const RenderSettings& settings, int view,
                                        const RenderOptions& options);

  // A light field's scene integral: each pixel integrated through each of `cells` alone
  // (radiance_integrator.h), with the lens's baseline blur; not cached. Errors: those of
  // render().
  Result<LightFieldIntegral> integrate_light_field(const RenderSettings& settings, int view,
                                                   const RenderOptions& options,
                                                   const LightFieldCells& cells);

  // The settings the camera's control defaults give.
  RenderSettings default_settings() const;

  // Settings checked against the camera's control ranges, with a specific message.
  Status validate(const RenderSettings& settings) const;

  const CameraSpec& camera() const { return camera_; }
  const SceneSpec& scene() const { return scene_; }

  // Moves the target named `target` to `pose` in view `view` (a person moving the board
  // between shots; the guided calibration's tests place it at each suggestion). Drops
  // the cached scene integrals; the truth of later frames follows. Errors: "not_found"
  // (no such target), "out_of_range" (view, or the origin not in front of the camera).
  Status set_target_pose(const std::string& target, int view, const RtCamTarget& pose);

 private:
  Renderer() = default;
  struct FramePlan;  // renderer.cpp: everything a frame's integral and truth need
  Result<FramePlan> plan_frame(const RenderSettings& settings, int view,
                               const RenderOptions& options);
  // The integral for `plan`, from the cache or computed (and remembered).
  cv::Mat scene_integral(const FramePlan& plan, RenderStats* stats);
  // The scene integral (mean reflectance per pixel, each in its own channel; n values per
  // pixel for a light field's cells) for `setup`, with the lens's baseline blur.
  cv::Mat integrate(const IntegratorSetup& setup, RenderStats* stats) const;
  // The settings and truth render() attaches to a frame of `plan`.
  void describe_frame(const FramePlan& plan, const RenderStats& stats, const RenderOptions& options,
                      double electrons_per_unit_reflectance, nlohmann::json* settings,
                      nlohmann::json* truth) const;
  const ChiefRayTable& rays_for(int focus_position, int threads);
  const SceneIntegral* cached_integral(const IntegrationKey& key) const;
  void remember_integral(const IntegrationKey& key, const SceneIntegral& integral);

  static constexpr size_t kReflectanceCacheSize = 8;
  static constexpr size_t kRayTableCacheSize = 8;

  CameraSpec camera_;
  SceneSpec scene_;
  std::shared_ptr<const ChiefRayTable> reference_rays_;  // focused at infinity
  // By focus position, oldest first.
  std::vector<std::pair<int, std::shared_ptr<const ChiefRayTable>>> rays_by_focus_;
  std::vector<std::shared_ptr<const cv::Mat>> textures_;                 // one per target (or null)
  std::vector<std::shared_ptr<const CharucoPattern>> charuco_patterns_;  // one per target (or null)
  std::vector<std::pair<IntegrationKey, SceneIntegral>> integral_cache_;  // oldest first
};

}  // namespace camlab::mock
