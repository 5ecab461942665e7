// Field of view of a rectilinear lens focused at infinity, and 35-mm equivalents.
#include <cmath>
#include <numbers>

#include "optics/optics.h"

namespace camlab::optics {

Result<double> field_of_view_deg(double extent_mm, double focal_mm) {
  if (auto s = detail::require_positive_finite("extent_mm", extent_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  // atan2 instead of atan(extent / 2f): no overflow of the quotient for tiny f, and the
  // angle stays in (0, 180) deg for every finite positive input.
  return 2.0 * std::atan2(0.5 * extent_mm, focal_mm) * (180.0 / std::numbers::pi);
}

Result<FieldOfView> field_of_view(double focal_mm, double sensor_width_mm,
                                  double sensor_height_mm) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  if (auto s = detail::require_positive_finite("sensor_width_mm", sensor_width_mm); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_finite("sensor_height_mm", sensor_height_mm); !s) {
    return s.error();
  }
  const double diagonal = diagonal_mm(sensor_width_mm, sensor_height_mm);
  if (auto s = detail::require_finite_result("sensor diagonal (mm)", diagonal); !s) {
    return s.error();
  }
  return FieldOfView{*field_of_view_deg(sensor_width_mm, focal_mm),
                     *field_of_view_deg(sensor_height_mm, focal_mm),
                     *field_of_view_deg(diagonal, focal_mm)};
}

Result<double> equivalent_focal_mm(double focal_mm, double sensor_width_mm,
                                   double sensor_height_mm) {
  if (auto s = detail::require_positive_finite("focal_mm", focal_mm); !s) return s.error();
  auto crop = crop_factor(sensor_width_mm, sensor_height_mm);
  if (!crop) return crop.error();
  const double equivalent_mm = focal_mm * *crop;
  if (auto s = detail::require_finite_result("equivalent focal length (mm)", equivalent_mm); !s) {
    return s.error();
  }
  return equivalent_mm;
}

}  // namespace camlab::optics
