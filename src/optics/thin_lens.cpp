// Thin lens 1/f = 1/z_i + 1/z_o, aperture A = f/N, and the argument checks shared by the
// whole module (optics.h, namespace detail).
#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>

#include "optics/optics.h"

#include "base/format.h"

namespace camlab::optics {

namespace detail {

namespace {
Error out_of_range(std::string_view name, double value, std::string_view allowed) {
  return make_error(kErrInvalidArgument, std::string(name) + " = " + format_significant(value, 10) +
                                             " is out of range: must be " + std::string(allowed));
}
}  // namespace

Status require_positive_finite(std::string_view name, double value) {
  // Written so that NaN fails too (every comparison with NaN is false).
  if (!(value > 0.0 && std::isfinite(value))) {
    return out_of_range(name, value, "finite and > 0");
  }
  return {};
}

Status require_positive_or_infinite(std::string_view name, double value) {
  if (!(value > 0.0)) return out_of_range(name, value, "> 0 (infinity allowed)");
  return {};
}

Status require_non_negative_finite(std::string_view name, double value) {
  if (!(value >= 0.0 && std::isfinite(value))) {
    return out_of_range(name, value, "finite and >= 0");
  }
  return {};
}

Status require_finite_result(std::string_view name, double value) {
  if (!std::isfinite(value)) {
    return make_error(kErrInvalidArgument, "the inputs are too extreme: " + std::string(name) +
                                               " = " + format_significant(value, 10) +
                                               " is not representable");
  }
  return {};
}

}  // namespace detail

namespace {

// z_i = f z_o / (z_o - f) for an object (or focus) at `object_name` = object_mm.
Result<double> conjugate_distance_mm(double focal_mm, double object_mm,
                                     std::string_view object_name) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_or_infinite(object_name, object_mm); !s) {
    return s.error();
  }
  if (std::isinf(object_mm)) return focal_mm;
  if (object_mm <= focal_mm) {
    return make_error(kErrNoRealImage,
                      std::string(object_name) + " = " + format_significant(object_mm, 10) +
                          " must be > focal_mm = " + format_significant(focal_mm, 10) +
                          ": at or inside the focal length a thin lens forms no real image");
  }
  // Near f, z_o - f is exact (Sterbenz) and z_o / (z_o - f) cannot overflow; far away,
  // f / (1 - f/z_o) keeps f z_o from overflowing for huge z_o and loses nothing since
  // f/z_o <= 1/2.
  const double image_mm = object_mm < 2.0 * focal_mm
                              ? focal_mm * (object_mm / (object_mm - focal_mm))
                              : focal_mm / (1.0 - focal_mm / object_mm);
  if (auto s = detail::require_finite_result("image distance (mm)", image_mm); !s) {
    return s.error();
  }
  return image_mm;
}

}  // namespace

Result<double> image_distance_mm(double focal_mm, double object_mm) {
  return conjugate_distance_mm(focal_mm, object_mm, "object_mm");
}

Result<double> magnification(double focal_mm, double object_mm) {
  // Validation (and the no-real-image case) as for the image distance.
  auto image = conjugate_distance_mm(focal_mm, object_mm, "object_mm");
  if (!image) return image.error();
  if (std::isinf(object_mm)) return 0.0;
  // f / (z_o - f) rather than z_i / z_o: one rounding, and z_o - f is exact near f.
  const double m = focal_mm / (object_mm - focal_mm);
  if (auto s = detail::require_finite_result("magnification", m); !s) return s.error();
  return m;
}

Result<double> lens_to_sensor_mm(double focal_mm, double focus_mm) {
  return conjugate_distance_mm(focal_mm, focus_mm, "focus_mm");
}

Result<double> focus_distance_mm(double focal_mm, double lens_to_sensor_mm) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("lens_to_sensor_mm", lens_to_sensor_mm); !s) {
    return s.error();
  }
  // The sensor at f sees infinity in focus; closer than f nothing focuses.
  if (lens_to_sensor_mm == focal_mm) return kInfinity;
  // The thin-lens equation is symmetric in z_o and z_i.
  return conjugate_distance_mm(focal_mm, lens_to_sensor_mm, "lens_to_sensor_mm");
}

Result<double> aperture_diameter_mm(double focal_mm, double f_number) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  const double aperture_mm = focal_mm / f_number;
  if (auto s = detail::require_finite_result("aperture diameter (mm)", aperture_mm); !s) {
    return s.error();
  }
  return aperture_mm;
}

}  // namespace camlab::optics
