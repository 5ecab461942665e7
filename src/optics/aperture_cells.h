// The sub-apertures of a light field: a grid of U x V square cells over the lens's
// aperture disk (docs/physics.md, "Light fields").
//
// A light-field camera records, for each point of the sensor, the light that came
// through each cell of the aperture separately: the sub-aperture image (view) (i, j) is
// what the sensor would see through the part of the aperture disk inside cell (i, j)
// alone. The grid spans the disk's bounding square; corner cells of a fine grid miss the
// disk entirely, and cells on its rim hold only part of a square. What a view's geometry
// needs is the region's share of the disk, its centroid (the view's effective lens
// point: its disparity is proportional to it) and its second moments (the spread of
// lens points inside it, which blurs the view).
//
// Coordinates are in units of the aperture radius R = A / 2, x and y along the sensor's
// x and y, the disk centred at 0. Cell (i, j) spans x in [-1 + 2i/U, -1 + 2(i+1)/U] and
// y in [-1 + 2j/V, -1 + 2(j+1)/V].
//
// Reentrant: pure functions. Standard library only (src/optics links nothing).
#pragma once

#include <vector>

#include "base/result.h"

namespace camlab::optics {

// Area and moments of (disk of radius `radius` centred at 0) intersected with the
// rectangle [x0, x1] x [y0, y1]: exact to rounding (the integrals in x are taken in
// theta = asin(x / radius), where every integrand is smooth).
struct RegionMoments {
  double area = 0;
  double sum_x = 0, sum_y = 0;    // integral of x, of y over the region
  double sum_xx = 0, sum_yy = 0;  // integral of x^2, of y^2
  double centroid_x() const { return area > 0 ? sum_x / area : 0; }
  double centroid_y() const { return area > 0 ? sum_y / area : 0; }
};
RegionMoments disk_rect_moments(double x0, double x1, double y0, double y1, double radius = 1.0);

// One cell of the grid, in units of the aperture radius.
struct ApertureCell {
  int u_index = 0, v_index = 0;  // i along x, j along y
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  double area_share = 0;  // of the disk, 0..1 (0: the cell misses the disk)
  // A full square's share of its cell that lies inside the disk, 0..1: what a white
  // (flat-field) image shows behind a microlens.
  double lit_share = 0;
  double centroid_x = 0, centroid_y = 0;  // of the lit part (0 when none)
  // Mean of x^2 and y^2 over the lit part (about the disk's centre, not the centroid).
  double mean_xx = 0, mean_yy = 0;
};

// The U x V cells in row-major order (index j U + i). Errors: "out_of_range" unless
// 1 <= views_u, views_v <= 64.
Result<std::vector<ApertureCell>> aperture_cells(int views_u, int views_v);

}  // namespace camlab::optics
