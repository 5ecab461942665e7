#include "analysis/defocus/chromatic_aberration.h"

#include <cmath>
#include <string>

namespace camlab::analysis {

namespace {

const TargetDefocus* find_target(const DefocusReport& report, const std::string& name) {
  for (const TargetDefocus& t : report.targets)
    if (t.name == name) return &t;
  return nullptr;
}

// Lens-to-sensor distance at the V-curve's minimum, and its sigma.
bool from_v_curve(const TargetDefocus& t, double* z_mm, double* sigma_mm) {
  if (!t.v_curve || !t.best_lens_to_sensor_mm || !(t.mm_per_step > 0)) return false;
  *z_mm = *t.best_lens_to_sensor_mm;
  *sigma_mm = t.v_curve->best_position_sigma * t.mm_per_step;
  return true;
}

// Image distance from C x N, on side `side` of the sensor.
bool from_aperture(const TargetDefocus& t, double side, double* z_mm, double* sigma_mm) {
  if (!t.aperture || t.frames.empty() || !(t.implied_defocus >= 0)) return false;
  const double zs = t.frames.front().lens_to_sensor_mm;
  const double denominator = 1 + side * t.implied_defocus;
  if (!(zs > 0) || !(denominator > 0)) return false;
  *z_mm = zs / denominator;
  *sigma_mm = zs * t.implied_defocus_sigma / (denominator * denominator);
  return true;
}

}  // namespace

std::vector<ChromaticFocusShift> longitudinal_chromatic_aberration(
    const std::vector<DefocusReport>& channels) {
  const DefocusReport* by_colour[3] = {nullptr, nullptr, nullptr};
  for (const DefocusReport& r : channels) {
    if (r.channel == "R") by_colour[0] = &r;
    if (r.channel == "G") by_colour[1] = &r;
    if (r.channel == "B") by_colour[2] = &r;
  }
  std::vector<ChromaticFocusShift> out;
  if (!by_colour[0] || !by_colour[1] || !by_colour[2]) return out;
  for (const TargetDefocus& green : by_colour[1]->targets) {
    const TargetDefocus* t[3] = {find_target(*by_colour[0], green.name), &green,
                                 find_target(*by_colour[2], green.name)};
    if (!t[0] || !t[2]) continue;
    ChromaticFocusShift shift;
    shift.target = green.name;
    double z[3], sigma[3];
    bool ok = true;
    for (int c = 0; c < 3 && ok; ++c) ok = from_v_curve(*t[c], &z[c], &sigma[c]);
    if (ok) {
      shift.method = "v_curve";
    } else {
      // The side of the sensor: an object beyond the focus distance images in front of it.
      double side = 1;
      const double focus_mm = by_colour[1]->focus_distance_mm;
      if (green.distance_m && focus_mm > 0) {
        side = *green.distance_m * 1e3 > focus_mm ? 1 : -1;
      } else {
        shift.side_assumed = true;
      }
      ok = true;
      for (int c = 0; c < 3 && ok; ++c) ok = from_aperture(*t[c], side, &z[c], &sigma[c]);
      if (!ok) continue;
      shift.method = "aperture";
      static const char* const kNames[3] = {"R", "G", "B"};
      for (int c = 0; c < 3; ++c)
        if (t[c]->implied_defocus < 2 * t[c]->implied_defocus_sigma)
          shift.warning += std::string(shift.warning.empty() ? "" : "; ") + kNames[c] +
                           " focuses within two sigma of the sensor: which side it lies on "
                           "is uncertain, so its shift may have the wrong sign";
    }
    for (int c = 0; c < 3; ++c) shift.image_distance_mm[c] = z[c];
    shift.shift_r_mm = z[0] - z[1];
    shift.shift_b_mm = z[2] - z[1];
    shift.shift_r_sigma_mm = std::hypot(sigma[0], sigma[1]);
    shift.shift_b_sigma_mm = std::hypot(sigma[2], sigma[1]);
    out.push_back(shift);
  }
  return out;
}

}  // namespace camlab::analysis
