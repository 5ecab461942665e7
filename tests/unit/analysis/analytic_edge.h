// An edge blurred by a uniform disk, written out independently of camlab's edge model:
// the fraction of the disk that falls on the light side, averaged over the pixel's area by
// supersampling. For test data that camlab's renderer and fits must not share a mistake
// with.
#pragma once

#include <cmath>
#include <numbers>

namespace camlab::analysis::testing {

// Light fraction of a disk of radius r whose centre lies at signed distance h from the
// edge (h > 0 on the light side): one minus the circular segment beyond the chord.
inline double disk_light_fraction(double h, double r) {
  if (r <= 0) return h > 0 ? 1.0 : (h < 0 ? 0.0 : 0.5);
  if (h >= r) return 1.0;
  if (h <= -r) return 0.0;
  const double a = std::fabs(h);
  const double segment = r * r * std::acos(a / r) - a * std::sqrt(r * r - a * a);
  const double dark = segment / (std::numbers::pi * r * r);
  return h >= 0 ? 1.0 - dark : dark;
}

// The light fraction seen by a unit-square pixel whose centre is at signed distance d from
// an edge of unit normal (nx, ny), for a blur disk of diameter `diameter` (ss x ss samples).
inline double pixel_light_fraction(double d, double diameter, double nx, double ny, int ss = 16) {
  const double r = 0.5 * diameter;
  if (d > r + 1) return 1.0;
  if (d < -r - 1) return 0.0;
  double sum = 0;
  for (int i = 0; i < ss; ++i)
    for (int j = 0; j < ss; ++j)
      sum += disk_light_fraction(d + nx * ((i + 0.5) / ss - 0.5) + ny * ((j + 0.5) / ss - 0.5), r);
  return sum / (ss * ss);
}

}  // namespace camlab::analysis::testing
