// One cell of a light field's aperture grid (optics/aperture_cells.h) as the renderer
// integrates over it: the part of the unit aperture disk inside a rectangle, in units of
// the aperture radius R.
//
// A sub-aperture view is the thin-lens render with the aperture disk replaced by this
// region, so each of the renderer's paths (radiance_integrator.h) needs its version of
// the region:
// - a straight edge: the share of the region on the positive side of a line
//   {p : dir . p + h > 0} (dir the unit normal towards the positive side, h its offset in
//   units of R: edge_coverage.h's h for the whole disk), exact: the rectangle clipped by
//   the half-plane, intersected with the disk (the triangle fan of a convex polygon
//   against a circle). Over a pixel on which h is linear the mean of that share is a 1-D
//   integral against the density of h (a trapezoid), taken piecewise between the points
//   where the share's derivative jumps (the region's vertices seen along dir, the
//   trapezoid's corners), 4 Gauss points a piece: exact where the region is a polygon
//   (the share is quadratic there), to about 1e-6 on arcs.
// - a smooth pattern: a product cubature rule over the region (Gauss in x, split where
//   the circle meets the rectangle and taken in theta = asin x, Gauss in y between the
//   region's bounds at that x), weights summing to 1.
// - random samples: a stratified point (a, b) of the unit square mapped onto the region
//   (x uniform over its x-extent, y uniform between its bounds there) with the weight
//   that makes the weighted mean unbiased.
//
// Immutable after construction; thread-safe for concurrent reads.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace camlab::mock {

class ApertureRegion {
 public:
  // The unit disk inside [x0, x1] x [y0, y1] (units of R).
  ApertureRegion(double x0, double x1, double y0, double y1);

  bool empty() const { return area_ <= 0; }
  double area() const { return area_; }  // in R^2 (the disk: pi)
  double centroid_x() const { return centroid_[0]; }
  double centroid_y() const { return centroid_[1]; }
  double x0() const { return x0_; }
  double x1() const { return x1_; }
  double y0() const { return y0_; }
  double y1() const { return y1_; }

  // Share (0..1) of the region where dir . p + h > 0; dir a unit vector.
  double coverage(double h, double dir_x, double dir_y) const;

  // The mean of coverage(h, dir) over a pixel on which h is linear: h_centre at its
  // centre, changing by slope_a across it in one direction and by slope_b in the other.
  double pixel_mean_coverage(double h_centre, double slope_a, double slope_b, double dir_x,
                             double dir_y) const;

  // How fast coverage can change with h (per unit of h), and the range of h over which it
  // changes: bounds for the caller's error estimate of a linearised h.
  double max_coverage_slope() const { return max_slope_; }
  double coverage_span() const { return span_; }

  // A cubature rule of `order` Gauss points per direction (and per piece of the region in
  // x), weights summing to 1. `order` 1..4.
  struct Point {
    double x, y, w;
  };
  const std::vector<Point>& rule(int order) const {
    return rules_[static_cast<size_t>(order < 1 ? 1 : order > 4 ? 4 : order)];
  }

  // (a, b) in [0, 1)^2 -> a point of the region and its weight (the weighted mean over
  // uniform (a, b) is the region's mean; weight 0 where the column at a misses it).
  void sample(double a, double b, double* x, double* y, double* weight) const;

 private:
  // The y-range of the region at x (empty when lo >= hi).
  void bounds_at(double x, double* lo, double* hi) const;
  // Area of the region where dir . p + h > 0 (R^2).
  double area_positive(double h, double dir_x, double dir_y) const;

  double x0_, x1_, y0_, y1_;
  double xa_, xb_;  // the region's x-extent
  double area_ = 0;
  std::array<double, 2> centroid_{0, 0};
  bool inside_disk_ = false;  // the whole rectangle lies in the disk: a polygon
  // Points where the region's boundary turns: rectangle corners in the disk and the
  // rectangle's crossings with the circle.
  std::vector<std::array<double, 2>> vertices_;
  double max_slope_ = 0, span_ = 0;
  std::array<std::vector<Point>, 5> rules_;  // by order (0 unused)
};

}  // namespace camlab::mock
