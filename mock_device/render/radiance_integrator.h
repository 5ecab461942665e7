// The inner loop of the renderer: mean reflectance seen by each pixel, integrated over
// the pixel's area and (when the lens is sampled) over the aperture disk.
//
// Two ways to integrate:
// - uniform (explicit sample counts, and the reference the fast paths are measured
//   against): every pixel takes the channel's lens_grid^2 stratified samples (or
//   pixel_grid^2 area samples without the lens), tracing every target;
// - adaptive (the automatic rule): each 8x8 block, then each 4x4 quarter, then each pixel,
//   is classified by the footprint of its rays (footprint.h). A footprint on one flat
//   patch takes that patch's value, exactly; one on a single straight edge between two
//   flat patches takes the closed-form coverage of edge_coverage.h; one on a texture alone
//   takes a fixed cubature rule sized to how many of its features the pixel and the blur
//   span (pixel_quadrature.h); anything else is sampled as above, with the lens grid the
//   rule gives for the blur of the targets that pixel can see (not the frame's worst), at
//   least 64 samples where it sees steps, tracing only those targets.
//
// A pixel sees one channel: grey on a monochrome sensor, its own colour on a Bayer
// sensor, so a colour frame costs what a grey one does. Each channel has its own plane of
// focus (longitudinal chromatic aberration) and its own lens sample count; with a focus
// surface (field_focus.h) each pixel's plane of focus is its own, and a block's rays are
// classified over the range of planes its pixels focus on.
//
// A light field (setup.cells): every pixel is integrated once per sub-aperture, with the
// aperture disk replaced by that cell of it (aperture_region.h). The classification of
// blocks and pixels is the whole disk's, which bounds every cell's, so a pixel that sees
// one flat patch through the disk sees it through every cell; a straight edge takes each
// cell's exact coverage, a texture each cell's cubature rule, the rest stratified samples
// inside each cell. The cells' values are weighted means over the cells, so their
// area-weighted sum is the whole disk's value.
//
// Reentrant: reads only its arguments.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "mock_device/render/aperture_region.h"
#include "mock_device/render/chief_ray_table.h"
#include "mock_device/render/field_focus.h"
#include "mock_device/render/target_surface.h"

namespace camlab::mock {

// What one channel (kRed .. kGrey) sees through the lens.
struct ChannelSetup {
  double background_reflectance = 0;
  // The channel's plane of focus (m): +infinity when it focuses at infinity; negative
  // when it focuses "beyond infinity" (its focal length exceeds the lens-to-sensor
  // distance, so the rays of a pixel diverge into the scene as if they came from a point
  // that far behind the lens).
  double focus_distance_m = 0;
  int lens_grid = 0;  // k: k x k stratified lens samples; 0 = pinhole
  // The channel's focal length, read with a focus surface only (IntegratorSetup::
  // field_focus), where each pixel's plane of focus is its own.
  double focal_mm = 0;
  // Lateral colour: the channel sees through the chief rays' normalised coordinates times
  // this (1 / the channel's image scale), so its image is 1 / ray_scale times the
  // nominal one about the principal point.
  double ray_scale = 1;
  // An astigmatic pixel's (field_focus.h): 1 / the plane of focus (1/m) of the aperture's
  // radial component (meridional) and of its tangential one (sagittal); NaN: stigmatic,
  // every ray through focus_distance_m's point.
  double inverse_focus_meridional_m = NAN, inverse_focus_sagittal_m = NAN;
};

struct IntegratorSetup {
  const ChiefRayTable* rays = nullptr;
  const std::vector<TargetSurface>* surfaces = nullptr;
  // A tilted or curved best-focus surface (field_focus.h): each pixel's plane of focus
  // from its place on the sensor instead of the channel's focus_distance_m. None: flat.
  std::optional<FieldFocus> field_focus;
  double aperture_radius_m = 0;          // A / 2, the same for every channel
  std::array<ChannelSetup, 4> channels;  // by channel, kRed .. kGrey
  // The channel each pixel sees: a Bayer order ("RGGB" ...: the top-left 2x2 pixels,
  // row by row), or "" for `channel` at every pixel.
  std::string cfa;
  int channel = kGrey;
  int pixel_grid = 4;  // m: m x m area samples when the lens is not sampled
  uint64_t seed = 0;
  int threads = 1;
  bool adaptive = false;  // the automatic rule (above); false: uniform sampling
  // A light field's sub-apertures (none empty), in units of the aperture radius; null:
  // the whole disk, one value per pixel.
  const std::vector<ApertureRegion>* cells = nullptr;
  // Sub-apertures per side of the grid the cells come from (their blur is the disk's
  // over this); 1 without cells.
  int cells_per_side = 1;
};

// Values per pixel: one per cell of a light field, else 1.
inline int values_per_pixel(const IntegratorSetup& s) {
  return s.cells ? static_cast<int>(s.cells->size()) : 1;
}

// Where the adaptive path spent its work (pixels by path, and the samples taken).
struct IntegratorStats {
  long flat_pixels = 0;          // one value, exactly
  long edge_pixels = 0;          // one straight edge, closed form
  long edge_sampled_pixels = 0;  // one straight edge, exact lens coverage at area samples
  long smooth_pixels = 0;        // one smooth pattern, a fixed cubature rule
  long sampled_pixels = 0;       // rays traced at random
  long evaluations = 0;          // rays traced + coverage evaluations (flat pixels: 1)
  int max_lens_grid = 0;         // the largest lens grid a pixel took

  // Adds another part's counts (a thread's rows, a colour channel's plane).
  IntegratorStats& operator+=(const IntegratorStats& other) {
    flat_pixels += other.flat_pixels;
    edge_pixels += other.edge_pixels;
    edge_sampled_pixels += other.edge_sampled_pixels;
    smooth_pixels += other.smooth_pixels;
    sampled_pixels += other.sampled_pixels;
    evaluations += other.evaluations;
    max_lens_grid = max_lens_grid > other.max_lens_grid ? max_lens_grid : other.max_lens_grid;
    return *this;
  }
};

// Returns a CV_32F image of mean reflectance, each pixel in its own channel: height x
// width of the ray table, or height x (width x n) for a light field of n cells (pixel x's
// n values side by side, in the cells' order). Pixels whose chief rays fall outside the
// lens model's domain are 0 (black), as a real lens with a mechanical vignette would show
// them.
cv::Mat integrate_reflectance(const IntegratorSetup& setup, IntegratorStats* stats = nullptr);

}  // namespace camlab::mock
