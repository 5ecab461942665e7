// Focus across the field: a lens whose best-focus surface is tilted and curved
// (lens.field_focus, docs/virtual-camera.md "Focus across the field"). A sensor point
// (X, Y) mm from the principal point is sharp for an object when the lens-to-sensor
// distance is the thin lens's image distance plus
//
//   delta(X, Y) = X tan(tilt_x) + Y tan(tilt_y) + sag (X^2 + Y^2) / R^2
//
// (R: the imager's half diagonal); with astigmatism the rays in the meridional plane (the
// aperture's radial component, towards the point) focus on delta - a rho^2 / 2 and the
// sagittal ones (its tangential component) on delta + a rho^2 / 2, a = astigmatism / R^2,
// so a point's pencil has two focal lines and its blur is an ellipse. So that point sees the scene
// as a flat-field lens would at the lens-to-sensor distance z_s - delta: its plane of focus, per
// channel of focal length f_c, is at 1 / q with q = 1/f_c - 1/(z_s - delta). The image itself does
// not move: the surface changes where each point is sharp, not where it is imaged (a tilt of a
// degree moves an image point by a few parts in 10^5 of its distance from the centre).
//
// Reentrant: plain values.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

struct FieldFocus {
  double lens_to_sensor_mm = 0;  // z_s of the frame
  double pixel_pitch_mm = 0;
  double centre_x_px = 0, centre_y_px = 0;  // the principal point (pixel centres at integers)
  double slope_x = 0, slope_y = 0;          // tan(tilt_x), tan(tilt_y)
  double curvature_per_mm2 = 0;             // sag / R^2
  double astigmatism_per_mm2 = 0;           // (sagittal - meridional at the corner) / R^2

  bool astigmatic() const { return astigmatism_per_mm2 != 0; }

  // The sagittal (+1) or meridional (-1) surface's delta (mm) at a point: delta +- a r^2 / 2.
  double offset_mm(double x_corner_px, double y_corner_px, int sagittal) const {
    const double x_mm = (x_corner_px - 0.5 - centre_x_px) * pixel_pitch_mm;
    const double y_mm = (y_corner_px - 0.5 - centre_y_px) * pixel_pitch_mm;
    return offset_mm(x_corner_px, y_corner_px) +
           sagittal * 0.5 * astigmatism_per_mm2 * (x_mm * x_mm + y_mm * y_mm);
  }

  // delta (mm) at a point given in the integrator's pixel-corner coordinates (pixel x
  // spans [x, x + 1], its centre at x + 0.5).
  double offset_mm(double x_corner_px, double y_corner_px) const {
    const double x_mm = (x_corner_px - 0.5 - centre_x_px) * pixel_pitch_mm;
    const double y_mm = (y_corner_px - 0.5 - centre_y_px) * pixel_pitch_mm;
    return slope_x * x_mm + slope_y * y_mm + curvature_per_mm2 * (x_mm * x_mm + y_mm * y_mm);
  }

  // q = 1 / (plane of focus), in 1/m, of a channel of focal length focal_mm at that
  // point: 0 at infinity, negative beyond it.
  double inverse_focus_m(double focal_mm, double x_corner_px, double y_corner_px) const {
    return inverse_focus_at_offset_m(focal_mm, offset_mm(x_corner_px, y_corner_px));
  }
  double inverse_focus_at_offset_m(double focal_mm, double delta_mm) const {
    return 1e3 * (1 / focal_mm - 1 / (lens_to_sensor_mm - delta_mm));
  }

  // The least and greatest delta over the rectangle [x0, x1] x [y0, y1] (corner
  // coordinates): the linear part is extreme at the corners, the quadratic one at the
  // corner farthest from the centre and at the point nearest it.
  void offset_range_mm(double x0, double x1, double y0, double y1, double* lo, double* hi) const {
    const double xs[2] = {x0, x1}, ys[2] = {y0, y1};
    double linear_lo = INFINITY, linear_hi = -INFINITY, r2_hi = 0;
    for (double x : xs)
      for (double y : ys) {
        const double x_mm = (x - 0.5 - centre_x_px) * pixel_pitch_mm;
        const double y_mm = (y - 0.5 - centre_y_px) * pixel_pitch_mm;
        const double linear = slope_x * x_mm + slope_y * y_mm;
        linear_lo = std::min(linear_lo, linear);
        linear_hi = std::max(linear_hi, linear);
        r2_hi = std::max(r2_hi, x_mm * x_mm + y_mm * y_mm);
      }
    const double nx = (std::clamp(centre_x_px + 0.5, x0, x1) - 0.5 - centre_x_px) * pixel_pitch_mm;
    const double ny = (std::clamp(centre_y_px + 0.5, y0, y1) - 0.5 - centre_y_px) * pixel_pitch_mm;
    const double r2_lo = nx * nx + ny * ny;
    // The medial surface's curvature and either focal surface's: every delta a ray of the
    // rectangle focuses on.
    const double spread = 0.5 * std::fabs(astigmatism_per_mm2);
    const double c_lo = curvature_per_mm2 - spread, c_hi = curvature_per_mm2 + spread;
    const double quad_lo = std::min({c_lo * r2_lo, c_lo * r2_hi, c_hi * r2_lo, c_hi * r2_hi});
    const double quad_hi = std::max({c_lo * r2_lo, c_lo * r2_hi, c_hi * r2_lo, c_hi * r2_hi});
    *lo = linear_lo + quad_lo;
    *hi = linear_hi + quad_hi;
  }
};

// The camera's focus surface for a frame whose lens sits lens_to_sensor_mm from the
// sensor; none when lens.field_focus is flat.
inline std::optional<FieldFocus> make_field_focus(const CameraSpec& camera,
                                                  double lens_to_sensor_mm) {
  const FieldFocusSpec& ff = camera.lens.field_focus;
  if (ff.flat()) return std::nullopt;
  const double pitch_mm = camera.sensor.pixel_pitch_um * 1e-3;
  const double half_diagonal_mm =
      0.5 * std::hypot(camera.sensor.width_px, camera.sensor.height_px) * pitch_mm;
  const double rad = M_PI / 180;
  return FieldFocus{lens_to_sensor_mm,
                    pitch_mm,
                    camera.lens.principal_point_px[0],
                    camera.lens.principal_point_px[1],
                    std::tan(ff.tilt_x_deg * rad),
                    std::tan(ff.tilt_y_deg * rad),
                    ff.curvature_sag_um * 1e-3 / (half_diagonal_mm * half_diagonal_mm),
                    ff.astigmatism_um * 1e-3 / (half_diagonal_mm * half_diagonal_mm)};
}

}  // namespace camlab::mock
