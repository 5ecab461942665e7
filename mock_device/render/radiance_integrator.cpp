#include "mock_device/render/radiance_integrator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <thread>

#include "mock_device/render/edge_coverage.h"
#include "mock_device/render/footprint.h"
#include "mock_device/render/pixel_quadrature.h"
#include "mock_device/render/sampling.h"

namespace camlab::mock {

namespace {

// Pixels per side of the blocks classified before their pixels (the table keeps their
// bounds).
constexpr int kBlock = ChiefRayTable::kBlockPx;
// Coverage error (share of the edge's contrast) the closed form may make on one pixel
// before the pixel's area is sampled instead (edge_coverage.h).
constexpr double kEdgeTolerance = 5e-4;
// Area samples of an edge pixel whose h is too far from linear for the closed form.
constexpr int kEdgeAreaGrid = 4;
// A pixel that sees one smooth pattern (a texture) takes a fixed cubature rule sized to the
// pattern (pixel_quadrature.h) unless that would take more than this many points; then
// random samples. On the example texture (tilted 62 degrees, 4 mm features, blur 1-2 px)
// 0.017% RMS of the contrast against 0.18% for the 16 random samples the rule gives
// (docs/BENCHMARKS.md); on a focus sweep of a 1.6 px texture 0.05-0.16% against 0.4-1.2%.
constexpr int kMaxSmoothPoints = 256;
// Least grid (per side) of a sampled pixel that sees steps: 64 samples.
constexpr int kStepGrid = 8;
// The most cells a light field may have (the edge path's scratch).
constexpr int kMaxCells = 1024;

// The channel of each pixel of a 2x2 cell, indexed 2 (y & 1) + (x & 1).
std::array<int, 4> channels_of_cell(const IntegratorSetup& s) {
  std::array<int, 4> cell = {s.channel, s.channel, s.channel, s.channel};
  if (s.cfa.size() == 4)
    for (size_t i = 0; i < 4; ++i)
      cell[i] = s.cfa[i] == 'R' ? kRed : s.cfa[i] == 'G' ? kGreen : kBlue;
  return cell;
}

// q = 1 / s (1/m) of a channel's plane of focus: 0 at infinity, negative beyond it.
double inverse_focus(const ChannelSetup& c) {
  return std::isfinite(c.focus_distance_m) ? 1 / c.focus_distance_m : 0.0;
}

// Channel c as the pixel whose centre is at corner coordinates (x + 0.5, y + 0.5) sees it:
// its own plane of focus on a tilted or curved focus surface, the channel's otherwise.
ChannelSetup channel_at_pixel(const IntegratorSetup& s, const ChannelSetup& c, int x, int y) {
  if (!s.field_focus) return c;
  ChannelSetup at = c;
  const FieldFocus& field = *s.field_focus;
  const double q = field.inverse_focus_m(c.focal_mm, x + 0.5, y + 0.5);
  at.focus_distance_m = q == 0 ? INFINITY : 1 / q;
  if (field.astigmatic()) {
    at.inverse_focus_sagittal_m =
        field.inverse_focus_at_offset_m(c.focal_mm, field.offset_mm(x + 0.5, y + 0.5, +1));
    at.inverse_focus_meridional_m =
        field.inverse_focus_at_offset_m(c.focal_mm, field.offset_mm(x + 0.5, y + 0.5, -1));
  }
  return at;
}

int largest_grid(const IntegratorSetup& s) {
  int max_n = s.pixel_grid * s.pixel_grid;
  for (const ChannelSetup& c : s.channels) max_n = std::max(max_n, c.lens_grid * c.lens_grid);
  return std::max(max_n, 16 * 16);
}

void integrate_rows_uniform(const IntegratorSetup& s, int first_row, int row_step, cv::Mat& out) {
  const ChiefRayTable& rays = *s.rays;
  const int width = rays.width_px(), height = rays.height_px();
  const int n = values_per_pixel(s);
  const std::array<int, 4> cell = channels_of_cell(s);
  std::vector<int> strata(static_cast<size_t>(largest_grid(s)));
  for (int y = first_row; y < height; y += row_step) {
    float* row = out.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      float* dst = row + static_cast<ptrdiff_t>(x) * n;
      if (!pixel_valid(rays, x, y)) {
        std::fill(dst, dst + n, 0.f);
        continue;
      }
      const int channel = cell[static_cast<size_t>(2 * (y & 1) + (x & 1))];
      const ChannelSetup c = channel_at_pixel(s, s.channels[static_cast<size_t>(channel)], x, y);
      const auto trace = [&](const double* o, const double* d) {
        return trace_ray(*s.surfaces, nullptr, 0, c.background_reflectance, o, d, channel);
      };
      if (s.cells)
        sample_pixel_cells(s, x, y, c, std::max(c.lens_grid, s.pixel_grid), strata.data(), trace,
                           dst);
      else
        dst[0] = static_cast<float>(
            sample_pixel(s, x, y, c, c.lens_grid, s.pixel_grid, strata.data(), trace));
    }
  }
}

// What the adaptive path shares between its threads (read-only).
struct AdaptiveContext {
  const IntegratorSetup* setup;
  std::vector<PlaneTarget> targets;
  std::vector<int> all_targets;  // 0 .. n-1
  std::array<int, 4> cell;
  std::array<double, 4> q;  // 1/s by channel
  double q_min, q_max;      // over the channels of the cell
  RegionValues background;
  double scale_min = 1, scale_max = 1;  // ray_scale over the channels of the cell
  bool astigmatic = false;              // pencils are elliptical: no closed forms

  double ray_scale(int channel) const {
    return setup->channels[static_cast<size_t>(channel)].ray_scale;
  }

  // 1/s of `channel` at corner coordinates (x, y): the channel's own without a focus
  // surface.
  double q_at(int channel, double x, double y) const {
    const IntegratorSetup& s = *setup;
    return s.field_focus ? s.field_focus->inverse_focus_m(
                               s.channels[static_cast<size_t>(channel)].focal_mm, x, y)
                         : q[static_cast<size_t>(channel)];
  }
  // The range of 1/s over the cell's channels and the corners' rectangle [x0, x1] x [y0, y1].
  void q_range(double x0, double x1, double y0, double y1, double* lo, double* hi) const {
    const IntegratorSetup& s = *setup;
    if (!s.field_focus) {
      *lo = q_min;
      *hi = q_max;
      return;
    }
    double delta_lo, delta_hi;
    s.field_focus->offset_range_mm(x0, x1, y0, y1, &delta_lo, &delta_hi);
    *lo = INFINITY;
    *hi = -INFINITY;
    for (int channel : cell)
      for (double delta : {delta_lo, delta_hi}) {
        const double v = s.field_focus->inverse_focus_at_offset_m(
            s.channels[static_cast<size_t>(channel)].focal_mm, delta);
        *lo = std::min(*lo, v);
        *hi = std::max(*hi, v);
      }
  }
};

int channel_at(const AdaptiveContext& ctx, int x, int y) {
  return ctx.cell[static_cast<size_t>(2 * (y & 1) + (x & 1))];
}

// The mean coverage of the edge's positive side over pixel (x, y) from its corners' edge
// terms, sampling the pixel's area (exact in the lens) where the closed form is not
// accurate enough.
double edge_coverage_of_pixel(const AdaptiveContext& ctx, const EdgeTerms corners_terms[4],
                              const ChiefRayTable& rays, int x, int y, double q,
                              const EdgeInCamera& edge, IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const double closed = pixel_edge_coverage(corners_terms, kEdgeTolerance);
  if (!std::isnan(closed)) {
    if (closed == 0 || closed == 1) {
      ++st.flat_pixels;
      ++st.evaluations;
    } else {
      ++st.edge_pixels;
      st.evaluations += 4;
    }
    return closed;
  }
  ++st.edge_sampled_pixels;
  const int grid = kEdgeAreaGrid;
  st.evaluations += grid * grid;
  const PixelCorners corners(rays, x, y, ctx.ray_scale(channel_at(ctx, x, y)));
  SplitMix64 rng(mix_seed(s.seed, static_cast<uint64_t>(y) * rays.width_px() + x));
  double sum = 0;
  for (int k = 0; k < grid * grid; ++k) {
    double xn, yn;
    corners.at(((k % grid) + rng.uniform()) / grid, ((k / grid) + rng.uniform()) / grid, &xn, &yn);
    sum += disk_coverage(aperture_edge_distance(edge, xn, yn, s.aperture_radius_m, q));
  }
  return sum / (grid * grid);
}

// The same for each cell of a light field, into cov[k]: each cell's exact coverage of the
// linearised h (aperture_region.h), unless a cell's error bound (its steepest coverage
// slope times the linearisation's error, over the share of the pixel where h crosses
// the cell) exceeds the tolerance: then the pixel's area is sampled, each cell's coverage
// exact at each sample.
void edge_coverage_of_pixel_cells(const AdaptiveContext& ctx, const EdgeTerms corners_terms[4],
                                  const ChiefRayTable& rays, int x, int y, double q,
                                  const EdgeInCamera& edge, double* cov, IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const std::vector<ApertureRegion>& cells = *s.cells;
  const size_t n = cells.size();
  const PixelH p = pixel_h(corners_terms);
  if (p.side == PixelH::kNegative || p.side == PixelH::kPositive) {
    std::fill(cov, cov + n, p.side == PixelH::kPositive ? 1.0 : 0.0);
    ++st.flat_pixels;
    ++st.evaluations;
    return;
  }
  bool exact = true;
  if (p.side == PixelH::kInFocus) {
    // Every lens point sees the edge's own line: the cells agree.
    exact = p.error_h <= kEdgeTolerance;
    if (exact) std::fill(cov, cov + n, pixel_positive_share(p.centre, p.slope_a, p.slope_b));
  } else {
    const double slope = std::max({std::fabs(p.slope_a), std::fabs(p.slope_b), 1e-300});
    for (size_t k = 0; k < n && exact; ++k) {
      const ApertureRegion& cell = cells[k];
      const double error = cell.max_coverage_slope() * (p.error_h + p.dir_error) *
                           std::min(1.0, cell.coverage_span() / slope);
      exact = error <= kEdgeTolerance;
      if (exact)
        cov[k] = cell.pixel_mean_coverage(p.centre, p.slope_a, p.slope_b, p.dir_x, p.dir_y);
    }
  }
  if (exact) {
    ++st.edge_pixels;
    st.evaluations += static_cast<long>(4 * n);
    return;
  }
  ++st.edge_sampled_pixels;
  const int grid = kEdgeAreaGrid;
  st.evaluations += static_cast<long>(grid * grid * n);
  const PixelCorners corners(rays, x, y, ctx.ray_scale(channel_at(ctx, x, y)));
  SplitMix64 rng(mix_seed(s.seed, static_cast<uint64_t>(y) * rays.width_px() + x));
  std::fill(cov, cov + n, 0.0);
  for (int k = 0; k < grid * grid; ++k) {
    double xn, yn;
    corners.at(((k % grid) + rng.uniform()) / grid, ((k / grid) + rng.uniform()) / grid, &xn, &yn);
    const EdgeTerms t = aperture_edge_terms(edge, xn, yn, s.aperture_radius_m, q);
    for (size_t c = 0; c < n; ++c) {
      if (t.w_norm == 0)
        cov[c] += t.signed_w0 > 0 ? 1 : 0;
      else
        cov[c] += cells[c].coverage(t.signed_w0 / t.w_norm, t.dir_x, t.dir_y);
    }
  }
  for (size_t c = 0; c < n; ++c) cov[c] /= grid * grid;
}

// Pixel (x, y)'s values (one, or one per cell) where its rays see one straight edge
// between the values lo and hi.
void fill_edge_pixel(const AdaptiveContext& ctx, const EdgeTerms corners_terms[4],
                     const ChiefRayTable& rays, int x, int y, double q, const EdgeInCamera& edge,
                     double lo, double hi, float* dst, IntegratorStats& st) {
  if (!ctx.setup->cells) {
    const double coverage = edge_coverage_of_pixel(ctx, corners_terms, rays, x, y, q, edge, st);
    dst[0] = static_cast<float>(lo + (hi - lo) * coverage);
    return;
  }
  const size_t n = ctx.setup->cells->size();
  double cov[kMaxCells];
  edge_coverage_of_pixel_cells(ctx, corners_terms, rays, x, y, q, edge, cov, st);
  for (size_t k = 0; k < n; ++k) dst[k] = static_cast<float>(lo + (hi - lo) * cov[k]);
}

// Pixels [x0, x1) x [y0, y1) whose rays all see one straight edge between two values:
// the edge's terms at every pixel corner once (per channel), then each pixel's coverage.
void fill_edge_region(const AdaptiveContext& ctx, const Footprint& fp, int x0, int x1, int y0,
                      int y1, cv::Mat& out, IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const ChiefRayTable& rays = *s.rays;
  const int n = values_per_pixel(s);
  constexpr int kSide = kBlock + 1;
  EdgeTerms terms[4][kSide * kSide];  // by channel, corner (i - x0) + kSide (j - y0)
  bool done[4] = {false, false, false, false};
  for (int y = y0; y < y1; ++y) {
    float* row = out.ptr<float>(y);
    for (int x = x0; x < x1; ++x) {
      const int channel = channel_at(ctx, x, y);
      const double q = ctx.q_at(channel, x + 0.5, y + 0.5);
      EdgeTerms* t = terms[channel];
      if (!done[channel]) {
        const double scale = ctx.ray_scale(channel);
        for (int j = y0; j <= y1; ++j)
          for (int i = x0; i <= x1; ++i)
            t[(i - x0) + kSide * (j - y0)] =
                aperture_edge_terms(fp.edge, rays.xn(i, j) * scale, rays.yn(i, j) * scale,
                                    s.aperture_radius_m, ctx.q_at(channel, i, j));
        done[channel] = true;
      }
      const int k = (x - x0) + kSide * (y - y0);
      const EdgeTerms corners[4] = {t[k], t[k + 1], t[k + kSide], t[k + kSide + 1]};
      fill_edge_pixel(ctx, corners, rays, x, y, q, fp.edge, fp.negative.by_channel[channel],
                      fp.positive.by_channel[channel], row + static_cast<ptrdiff_t>(x) * n, st);
    }
  }
}

void fill_flat_region(const AdaptiveContext& ctx, const RegionValues& value, int x0, int x1, int y0,
                      int y1, cv::Mat& out, IntegratorStats& st) {
  const int n = values_per_pixel(*ctx.setup);
  for (int y = y0; y < y1; ++y) {
    float* row = out.ptr<float>(y);
    for (int x = x0; x < x1; ++x)
      std::fill(row + static_cast<ptrdiff_t>(x) * n, row + static_cast<ptrdiff_t>(x + 1) * n,
                static_cast<float>(value.by_channel[channel_at(ctx, x, y)]));
  }
  st.flat_pixels += (y1 - y0) * (x1 - x0);
  st.evaluations += (y1 - y0) * (x1 - x0);
}

// Pixel (x, y)'s values (one, or one per cell of a light field) into dst.
void integrate_pixel(const AdaptiveContext& ctx, int x, int y, const int* candidates,
                     int candidate_count, int* hits, int* strata, float* dst, IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const ChiefRayTable& rays = *s.rays;
  const int n = values_per_pixel(s);
  if (!pixel_valid(rays, x, y)) {
    std::fill(dst, dst + n, 0.f);
    return;
  }
  const int channel = channel_at(ctx, x, y);
  const ChannelSetup c = channel_at_pixel(s, s.channels[static_cast<size_t>(channel)], x, y);
  const double q = ctx.q_at(channel, x + 0.5, y + 0.5);
  const PixelCorners corners(rays, x, y, c.ray_scale);
  FootprintQuery query;
  query.mx0 = std::min({corners.x[0], corners.x[1], corners.x[2], corners.x[3]});
  query.mx1 = std::max({corners.x[0], corners.x[1], corners.x[2], corners.x[3]});
  query.my0 = std::min({corners.y[0], corners.y[1], corners.y[2], corners.y[3]});
  query.my1 = std::max({corners.y[0], corners.y[1], corners.y[2], corners.y[3]});
  query.aperture_radius_m = s.aperture_radius_m;
  query.q_min = query.q_max = q;
  if (!std::isnan(c.inverse_focus_meridional_m)) {  // the footprint spans both focal lines
    query.q_min = std::min({q, c.inverse_focus_meridional_m, c.inverse_focus_sagittal_m});
    query.q_max = std::max({q, c.inverse_focus_meridional_m, c.inverse_focus_sagittal_m});
  }
  int hit_count = 0;
  const Footprint fp = classify_footprint(query, ctx.targets, candidates, candidate_count,
                                          ctx.background, hits, &hit_count);
  if (fp.kind == Footprint::kFlat) {
    ++st.flat_pixels;
    ++st.evaluations;
    std::fill(dst, dst + n, static_cast<float>(fp.flat.by_channel[channel]));
    return;
  }
  if (fp.kind == Footprint::kOneLine && !ctx.astigmatic) {
    EdgeTerms terms[4];
    for (int i = 0; i < 4; ++i)
      terms[i] = aperture_edge_terms(fp.edge, corners.x[i], corners.y[i], s.aperture_radius_m, q);
    fill_edge_pixel(ctx, terms, rays, x, y, q, fp.edge, fp.negative.by_channel[channel],
                    fp.positive.by_channel[channel], dst, st);
    return;
  }
  // The blur of what this pixel can see: the footprint's diameter over the pixel's size
  // (both normalised).
  const double ax = corners.x[1] - corners.x[0], ay = corners.y[1] - corners.y[0];
  const double bx = corners.x[2] - corners.x[0], by = corners.y[2] - corners.y[0];
  const double pixel_n = std::sqrt(std::fabs(ax * by - ay * bx));
  const double coc_px = 2 * fp.rho_max / pixel_n;
  const auto trace = [&](const double* o, const double* d) {
    return trace_ray(*s.surfaces, hits, hit_count, c.background_reflectance, o, d, channel);
  };
  // A smooth pattern: g x g Gauss points over the pixel's area and a disk rule of r rings
  // over the aperture, each sized to how much of the pattern it spans: the footprint's
  // features shared between the pixel and the blur in proportion to their sizes (px).
  const double pixel_features = fp.features_across / (1 + coc_px);
  const double disk_features = fp.features_across * coc_px / (1 + coc_px);
  const int gauss = pixel_features <= 1 ? 2 : pixel_features <= 2 ? 3 : pixel_features <= 3 ? 4 : 0;
  const int rings =
      coc_px < kNegligibleCocPx ? 0 : std::max(1, static_cast<int>(std::ceil(disk_features)));
  const int points = gauss * gauss * (rings == 0 ? 1 : 4 * rings * rings);
  if (fp.kind == Footprint::kSmooth && !ctx.astigmatic && gauss > 0 && rings <= kMaxDiskRings &&
      points <= kMaxSmoothPoints) {
    const DiskRule& disk = disk_rule(rings);
    const GaussRule& area = kGauss[gauss];
    ++st.smooth_pixels;
    // Every ray meets this one target inside its extent: the plane's hit and the texel
    // lookup, nothing else.
    const PlaneTarget& t = ctx.targets[static_cast<size_t>(fp.target)];
    const TargetSurface& surface = *t.surface;
    const auto on_texture = [&](const double* o, const double* d) {
      const double lambda =
          (t.c - (t.n[0] * o[0] + t.n[1] * o[1])) / (t.n[0] * d[0] + t.n[1] * d[1] + t.n[2] * d[2]);
      const double X[3] = {o[0] + lambda * d[0], o[1] + lambda * d[1], lambda * d[2]};
      const double u = t.au[0] * X[0] + t.au[1] * X[1] + t.au[2] * X[2] - t.au_t;
      const double v = t.av[0] * X[0] + t.av[1] * X[1] + t.av[2] * X[2] - t.av_t;
      return surface.texture_at(u, v, channel);
    };
    if (s.cells) {
      // A cell's blur is the disk's over the cells per side: its rule spans that share of
      // the disk's features (its centroid alone where the cell's blur is negligible).
      const double cell_features = disk_features / s.cells_per_side;
      const int order = coc_px / s.cells_per_side < kNegligibleCocPx
                            ? 1
                            : std::min(4, 1 + static_cast<int>(std::ceil(cell_features)));
      for (const ApertureRegion& cell : *s.cells)
        st.evaluations += static_cast<long>(area.n * area.n * cell.rule(order).size());
      smooth_pixel_cells(s, corners, c, area, order, on_texture, dst);
      return;
    }
    st.evaluations += area.n * area.n * disk.n;
    dst[0] = static_cast<float>(smooth_pixel(s, corners, c, area, disk, on_texture));
    return;
  }
  // Sampled at random, with the lens grid the rule gives for that blur; where the pixel
  // sees steps (corners, several targets) at least kStepGrid^2 samples, since a step
  // needs more than a smooth pattern and such pixels are few.
  int grid = lens_grid_for_coc(coc_px);
  int area_grid = s.pixel_grid;
  if (fp.steps) {
    if (grid > 0) grid = std::max(grid, kStepGrid);
    area_grid = std::max(area_grid, kStepGrid);
  }
  ++st.sampled_pixels;
  if (s.cells) {
    // Each cell's blur is the disk's over the cells per side; its samples pair lens
    // points inside the cell with as many area strata, at least the area grid's.
    const int cell_grid = std::max(lens_grid_for_coc(coc_px / s.cells_per_side), area_grid);
    st.evaluations += static_cast<long>(cell_grid * cell_grid * n);
    st.max_lens_grid = std::max(st.max_lens_grid, cell_grid);
    sample_pixel_cells(s, x, y, c, cell_grid, strata, trace, dst);
    return;
  }
  st.evaluations += grid > 0 ? grid * grid : area_grid * area_grid;
  st.max_lens_grid = std::max(st.max_lens_grid, grid);
  dst[0] = static_cast<float>(sample_pixel(s, x, y, c, grid, area_grid, strata, trace));
}

// Per-thread scratch of the adaptive path.
struct Scratch {
  std::vector<int> hits[3];  // targets a block, a sub-block and a pixel may hit
  std::vector<int> strata;
};

// Pixels [x0, x1) x [y0, y1) of one block (level 0: kBlock wide) or sub-block (level 1):
// classified as a whole first; flat and one-edge regions are filled at once, others split
// (a block into 4 sub-blocks) or integrated pixel by pixel.
void integrate_region(const AdaptiveContext& ctx, int x0, int x1, int y0, int y1, int level,
                      const int* candidates, int candidate_count, Scratch& scratch, cv::Mat& out,
                      IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const ChiefRayTable& rays = *s.rays;
  // The region's chief rays: the box of all its pixel corners, if all are valid (a block's
  // is kept with the table).
  FootprintQuery query;
  bool valid = true;
  if (level == 0) {
    const ChiefRayTable::BlockBounds& b = rays.block_bounds(x0 / kBlock, y0 / kBlock);
    valid = b.valid;
    query.mx0 = b.x_min;
    query.mx1 = b.x_max;
    query.my0 = b.y_min;
    query.my1 = b.y_max;
  } else {
    query.mx0 = query.my0 = std::numeric_limits<double>::max();
    query.mx1 = query.my1 = -std::numeric_limits<double>::max();
    for (int j = y0; j <= y1 && valid; ++j)
      for (int i = x0; i <= x1; ++i) {
        valid = valid && rays.valid(i, j);
        query.mx0 = std::min<double>(query.mx0, rays.xn(i, j));
        query.mx1 = std::max<double>(query.mx1, rays.xn(i, j));
        query.my0 = std::min<double>(query.my0, rays.yn(i, j));
        query.my1 = std::max<double>(query.my1, rays.yn(i, j));
      }
  }
  // Lateral colour: the box of the region's rays as the cell's channels see them.
  if (ctx.scale_min != 1 || ctx.scale_max != 1) {
    const double x0n = query.mx0, x1n = query.mx1, y0n = query.my0, y1n = query.my1;
    query.mx0 = std::min(x0n * ctx.scale_min, x0n * ctx.scale_max);
    query.mx1 = std::max(x1n * ctx.scale_min, x1n * ctx.scale_max);
    query.my0 = std::min(y0n * ctx.scale_min, y0n * ctx.scale_max);
    query.my1 = std::max(y1n * ctx.scale_min, y1n * ctx.scale_max);
  }
  int* hits = scratch.hits[level].data();
  int hit_count = candidate_count;
  if (valid) {
    query.aperture_radius_m = s.aperture_radius_m;
    ctx.q_range(x0, x1, y0, y1, &query.q_min, &query.q_max);
    const Footprint fp = classify_footprint(query, ctx.targets, candidates, candidate_count,
                                            ctx.background, hits, &hit_count);
    if (fp.kind == Footprint::kFlat) return fill_flat_region(ctx, fp.flat, x0, x1, y0, y1, out, st);
    // The closed forms assume a round pencil; an astigmatic one is sampled.
    if (fp.kind == Footprint::kOneLine && !ctx.astigmatic)
      return fill_edge_region(ctx, fp, x0, x1, y0, y1, out, st);
    candidates = hits;
  }
  if (level == 0 && x1 - x0 > 2 && y1 - y0 > 2) {
    const int xm = x0 + (x1 - x0) / 2, ym = y0 + (y1 - y0) / 2;
    const int xs[3] = {x0, xm, x1}, ys[3] = {y0, ym, y1};
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        integrate_region(ctx, xs[i], xs[i + 1], ys[j], ys[j + 1], 1, candidates, hit_count, scratch,
                         out, st);
    return;
  }
  const int n = values_per_pixel(s);
  for (int y = y0; y < y1; ++y) {
    float* row = out.ptr<float>(y);
    for (int x = x0; x < x1; ++x)
      integrate_pixel(ctx, x, y, candidates, hit_count, scratch.hits[2].data(),
                      scratch.strata.data(), row + static_cast<ptrdiff_t>(x) * n, st);
  }
}

void integrate_blocks(const AdaptiveContext& ctx, int first_block_row, int block_row_step,
                      cv::Mat& out, IntegratorStats& st) {
  const IntegratorSetup& s = *ctx.setup;
  const int width = s.rays->width_px(), height = s.rays->height_px();
  Scratch scratch;
  for (auto& h : scratch.hits) h.resize(ctx.targets.size() + 1);
  scratch.strata.resize(static_cast<size_t>(largest_grid(s)));
  for (int y0 = first_block_row * kBlock; y0 < height; y0 += block_row_step * kBlock)
    for (int x0 = 0; x0 < width; x0 += kBlock)
      integrate_region(ctx, x0, std::min(x0 + kBlock, width), y0, std::min(y0 + kBlock, height), 0,
                       ctx.all_targets.data(), static_cast<int>(ctx.all_targets.size()), scratch,
                       out, st);
}

}  // namespace

cv::Mat integrate_reflectance(const IntegratorSetup& setup, IntegratorStats* stats) {
  cv::Mat out(setup.rays->height_px(), setup.rays->width_px() * values_per_pixel(setup), CV_32F);
  const int threads = std::max(1, setup.threads);
  std::vector<std::thread> workers;
  if (!setup.adaptive) {
    for (int t = 1; t < threads; ++t)
      workers.emplace_back([&, t] { integrate_rows_uniform(setup, t, threads, out); });
    integrate_rows_uniform(setup, 0, threads, out);
    for (auto& w : workers) w.join();
    return out;
  }
  AdaptiveContext ctx;
  ctx.setup = &setup;
  ctx.targets = plane_targets(*setup.surfaces);
  ctx.all_targets.resize(ctx.targets.size());
  std::iota(ctx.all_targets.begin(), ctx.all_targets.end(), 0);
  ctx.cell = channels_of_cell(setup);
  for (int c = 0; c <= kGrey; ++c) {
    ctx.q[static_cast<size_t>(c)] = inverse_focus(setup.channels[static_cast<size_t>(c)]);
    ctx.background.by_channel[c] = setup.channels[static_cast<size_t>(c)].background_reflectance;
  }
  ctx.q_min = ctx.q_max = ctx.q[static_cast<size_t>(ctx.cell[0])];
  ctx.scale_min = ctx.scale_max = ctx.ray_scale(ctx.cell[0]);
  ctx.astigmatic = setup.field_focus && setup.field_focus->astigmatic();
  for (int channel : ctx.cell) {
    ctx.scale_min = std::min(ctx.scale_min, ctx.ray_scale(channel));
    ctx.scale_max = std::max(ctx.scale_max, ctx.ray_scale(channel));
    ctx.q_min = std::min(ctx.q_min, ctx.q[static_cast<size_t>(channel)]);
    ctx.q_max = std::max(ctx.q_max, ctx.q[static_cast<size_t>(channel)]);
  }
  std::vector<IntegratorStats> per_thread(static_cast<size_t>(threads));
  for (int t = 1; t < threads; ++t)
    workers.emplace_back(
        [&, t] { integrate_blocks(ctx, t, threads, out, per_thread[static_cast<size_t>(t)]); });
  integrate_blocks(ctx, 0, threads, out, per_thread[0]);
  for (auto& w : workers) w.join();
  if (stats) {
    *stats = IntegratorStats{};
    for (const IntegratorStats& p : per_thread) *stats += p;
  }
  return out;
}

}  // namespace camlab::mock
