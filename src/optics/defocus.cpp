// Circle of confusion, the diffraction floor, hyperfocal distance and depth of field,
// in forms that neither cancel nor produce NaN at infinite distances (docs/physics.md).
#include <cmath>
#include <string>
#include <string_view>

#include "optics/optics.h"

#include "base/format.h"

namespace camlab::optics {

namespace {

Error no_real_image(std::string_view name, double value_mm, double focal_mm,
                    std::string_view allowed) {
  return make_error(kErrNoRealImage,
                    std::string(name) + " = " + format_significant(value_mm, 10) + " must be " +
                        std::string(allowed) + " focal_mm = " + format_significant(focal_mm, 10) +
                        ": at or inside the focal length a thin lens forms no real image");
}

}  // namespace

Result<double> circle_of_confusion_mm(double focal_mm, double f_number, double focus_mm,
                                      double object_mm) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_or_infinite("focus_mm", focus_mm); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_or_infinite("object_mm", object_mm); !s) {
    return s.error();
  }
  // Focused at f the sensor would sit at infinity.
  if (focus_mm <= focal_mm) return no_real_image("focus_mm", focus_mm, focal_mm, ">");
  // Inside f the image is virtual; at f itself the rays leave parallel (handled below).
  if (object_mm < focal_mm) return no_real_image("object_mm", object_mm, focal_mm, ">=");

  const double aperture_mm = focal_mm / f_number;
  // Exact cases first: they hold for infinite distances too, where the general form would
  // compute inf / inf.
  if (object_mm == focus_mm) return 0.0;
  if (object_mm == focal_mm) return aperture_mm;

  // C = (f^2 / N) |z_o - s| / (z_o (s - f)) = A * f / (s - f) * |z_o - s| / z_o.
  // Grouped as a product of ratios so no intermediate overflows for large distances;
  // z_o - s and s - f are differences of inputs, exact when close (Sterbenz), so nothing
  // cancels however close the object is to the plane of focus.
  double coc_mm = 0.0;
  if (std::isinf(focus_mm)) {
    coc_mm = aperture_mm * (focal_mm / object_mm);  // |z_o - s| / s -> 1
  } else if (std::isinf(object_mm)) {
    coc_mm = aperture_mm * (focal_mm / (focus_mm - focal_mm));  // |z_o - s| / z_o -> 1
  } else {
    coc_mm = aperture_mm * (focal_mm / (focus_mm - focal_mm)) *
             (std::fabs(object_mm - focus_mm) / object_mm);
  }
  if (auto s = detail::require_finite_result("circle of confusion (mm)", coc_mm); !s) {
    return s.error();
  }
  return coc_mm;
}

Result<double> circle_of_confusion_px(double coc_mm, double pixel_pitch_um) {
  // A CoC of 0 (object in focus) is a valid input.
  if (auto s = detail::require_non_negative_finite("coc_mm", coc_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("pixel_pitch_um", pixel_pitch_um); !s) {
    return s.error();
  }
  const double coc_px = coc_mm * 1000.0 / pixel_pitch_um;
  if (auto s = detail::require_finite_result("circle of confusion (px)", coc_px); !s) {
    return s.error();
  }
  return coc_px;
}

Result<double> airy_diameter_um(double f_number, double wavelength_nm) {
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_finite("wavelength_nm", wavelength_nm); !s) {
    return s.error();
  }
  // Diameter to the first dark ring: 2 x 1.22 lambda N.
  const double airy_um = 2.44 * (wavelength_nm * 1e-3) * f_number;
  if (auto s = detail::require_finite_result("Airy disk diameter (um)", airy_um); !s) {
    return s.error();
  }
  return airy_um;
}

Result<double> hyperfocal_mm(double focal_mm, double f_number, double coc_mm) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_finite("coc_mm", coc_mm); !s) return s.error();
  // f^2 / (N c) as (f / N) (f / c): no overflow of f^2 or underflow of N c.
  const double hyperfocal = (focal_mm / f_number) * (focal_mm / coc_mm) + focal_mm;
  if (auto s = detail::require_finite_result("hyperfocal distance (mm)", hyperfocal); !s) {
    return s.error();
  }
  return hyperfocal;
}

Result<DepthOfField> depth_of_field(double focal_mm, double f_number, double focus_mm,
                                    double coc_mm) {
  auto hyperfocal = hyperfocal_mm(focal_mm, f_number, coc_mm);
  if (!hyperfocal) return hyperfocal.error();
  if (auto s = detail::require_positive_or_infinite("focus_mm", focus_mm); !s) {
    return s.error();
  }
  if (focus_mm <= focal_mm) return no_real_image("focus_mm", focus_mm, focal_mm, ">");

  const double H = *hyperfocal;
  // H - f = f^2 / (N c), computed directly rather than by subtracting f back out of H.
  const double h_minus_f = (focal_mm / f_number) * (focal_mm / coc_mm);

  DepthOfField dof{};
  dof.hyperfocal_mm = H;
  // When f^2 / (N c) < f (the aperture f/N is smaller than c) the formula puts the near
  // limit inside f, where nothing images: every real image from f on is then sharp enough
  // (the blur never exceeds A < c there), so the near limit is f itself.
  if (std::isinf(focus_mm)) {
    dof.near_mm = std::fmax(h_minus_f, focal_mm);
    dof.far_mm = kInfinity;
    dof.total_mm = kInfinity;
    return dof;
  }

  // D_N = s (H - f) / (H + s - 2f) = (H - f) / (1 + (H - 2f) / s), here as
  // s (H - f) / ((H - f) + (s - f)): a sum of positive terms (s > f), so the denominator
  // never cancels (H - 2f is negative when f < N c), and the ratio is <= 1 in floating
  // point too, which keeps near <= s.
  const double focus_minus_f = focus_mm - focal_mm;
  dof.near_mm = std::fmax(focus_mm * (h_minus_f / (h_minus_f + focus_minus_f)), focal_mm);

  // 1/D_F = (H - s) / (s (H - f)); at or beyond H the far limit is infinity. The second
  // test catches focus a rounding error short of H, where H - s would be 0 or negative.
  if (focus_mm >= H || focus_minus_f >= h_minus_f) {
    dof.far_mm = kInfinity;
    dof.total_mm = kInfinity;
    return dof;
  }
  // H - s as (H - f) - (s - f); the ratio is >= 1 in floating point, so far >= s. An
  // overflow to infinity here is the honest answer for focus a hair short of H.
  dof.far_mm = focus_mm * (h_minus_f / (h_minus_f - focus_minus_f));
  dof.total_mm = dof.far_mm - dof.near_mm;
  return dof;
}

}  // namespace camlab::optics
