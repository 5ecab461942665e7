// The optics of docs/physics.md as pure functions.
//
// Conventions: every length is in millimetres (`_mm`), angles in degrees (`_deg`),
// times in seconds (`_s`) unless the name says otherwise. An infinite distance is
// std::numeric_limits<double>::infinity() (kInfinity), never a sentinel number.
// No function returns NaN: invalid input (zero, negative, non-finite where a finite value
// is required, an object or focus at or inside the focal length where no real image
// exists) returns an Error whose code is stable and whose message names the value and
// the allowed range.
//
// Reentrant: no state. Depends on the standard library and the header-only base/result.h
// only (docs/architecture.md).
#pragma once

#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace camlab::optics {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Full-frame 36 x 24 mm (nominal) diagonal, the reference of crop factors and 35-mm
// equivalent focal lengths.
inline constexpr double kFullFrameDiagonal_mm = 43.266615305567875;

// The error codes this module returns (base/error_code.h).
inline constexpr ErrorCode kErrInvalidArgument = ErrorCode::kInvalidArgument;  // <= 0, NaN
inline constexpr ErrorCode kErrNoRealImage = ErrorCode::kNoRealImage;  // at/inside focal length
inline constexpr ErrorCode kErrUnknownSensor = ErrorCode::kInvalidArgument;  // not in the table

// Argument checks shared by the files of this module (defined in thin_lens.cpp). Each
// returns an Error with kErrInvalidArgument whose message names `name`, its value and the
// allowed range, e.g. "focal_mm = -5 is out of range: must be finite and > 0".
namespace detail {
// 0 < value < inf.
Status require_positive_finite(std::string_view name, double value);
// 0 < value <= inf: a distance that may be infinite.
Status require_positive_or_infinite(std::string_view name, double value);
// 0 <= value < inf.
Status require_non_negative_finite(std::string_view name, double value);
// A computed value left the range of double (inputs near the limits of double).
Status require_finite_result(std::string_view name, double value);
}  // namespace detail

// ---- Sensor formats ------------------------------------------------------------------

// A common sensor format (medium format through 1/3.2").
struct SensorFormat {
  std::string_view name;   // canonical CLI name: "medium-format", "full-frame", "aps-h",
                           // "aps-c", "four-thirds", "1in", "1/1.63in", "1/2.3in", "1/3.2in"
  std::string_view label;  // as usually printed: "Medium Format", "1/2.3\"", ...
  double width_mm;
  double height_mm;
};

// The table, largest first.
std::span<const SensorFormat> sensor_formats();

// Looks a format up by name, case-insensitively, accepting common spellings
// ("full-frame", "ff", "35mm", "aps-c", "apsc", "4/3", "m43", "1\"", "1in", "1/2.3", ...).
Result<SensorFormat> find_sensor_format(std::string_view name);

double diagonal_mm(double width_mm, double height_mm);

// Full-frame diagonal / this sensor's diagonal (APS-C 23.6 x 15.8 -> 1.52).
Result<double> crop_factor(double sensor_width_mm, double sensor_height_mm);

// ---- Field of view -------------------------------------------------------------------

// FOV = 2 atan(extent / 2f) of a rectilinear (distortion-free) lens focused at infinity.
Result<double> field_of_view_deg(double extent_mm, double focal_mm);

struct FieldOfView {
  double horizontal_deg;
  double vertical_deg;
  double diagonal_deg;
};
Result<FieldOfView> field_of_view(double focal_mm, double sensor_width_mm, double sensor_height_mm);

// 35-mm equivalent focal length: focal_mm x crop factor.
Result<double> equivalent_focal_mm(double focal_mm, double sensor_width_mm,
                                   double sensor_height_mm);

// ---- Thin lens: 1/f = 1/z_i + 1/z_o --------------------------------------------------

// Image distance z_i = f z_o / (z_o - f). object_mm may be kInfinity (-> f).
// object_mm <= focal_mm: kErrNoRealImage (at f the image is at infinity).
Result<double> image_distance_mm(double focal_mm, double object_mm);

// Lateral magnification m = z_i / z_o = f / (z_o - f) (0 for an object at infinity).
Result<double> magnification(double focal_mm, double object_mm);

// Lens-to-sensor distance that focuses at focus_mm (the same as image_distance_mm).
Result<double> lens_to_sensor_mm(double focal_mm, double focus_mm);

// Focus distance for a lens-to-sensor distance z_s: s = f z_s / (z_s - f).
// z_s == f -> kInfinity; z_s < f -> kErrNoRealImage.
Result<double> focus_distance_mm(double focal_mm, double lens_to_sensor_mm);

// ---- Aperture and exposure -----------------------------------------------------------

// A = f / N.
Result<double> aperture_diameter_mm(double focal_mm, double f_number);

enum class StopIncrement { kFull = 1, kHalf = 2, kThird = 3 };

// One f-stop of a series: `exact` is sqrt(2)^(k / increment); `marked` is what lenses
// engrave (1.4, 2.8, 5.6, 11, 22; for thirds 1.1, 1.2, 1.6, 1.8, 2.2, 2.5, ...).
struct FStop {
  double exact;
  double marked;
};

// The series from f/1 up to and including max_f_number (default f/32).
std::vector<FStop> f_stop_series(StopIncrement increment, double max_f_number = 32.0);

// EV = log2(N^2 / T) (EV at the sensitivity in use; EV100 subtracts log2(ISO/100)).
Result<double> exposure_value(double f_number, double exposure_s);

// Light gathered relative to f/1 for 1 s: T / N^2 (H = T x E with E ~ 1/N^2).
Result<double> relative_exposure(double f_number, double exposure_s);

// Photometric exposure H = T x E in lux seconds.
Result<double> photometric_exposure_lux_s(double illuminance_lux, double exposure_s);

// Exposure time that gives the same image brightness at another f-number and gain:
// T2 = T1 (N2/N1)^2 (g1/g2). Gain is linear (ISO 200 = gain 2 relative to ISO 100).
Result<double> equivalent_exposure_s(double exposure_s, double f_number, double gain,
                                     double new_f_number, double new_gain);

// Linear gain of a sensitivity relative to a base sensitivity (ISO 400 vs 100 -> 4).
Result<double> gain_from_iso(double iso, double base_iso = 100.0);

// ---- Circle of confusion and depth of field --------------------------------------------

// Blur-circle diameter on the sensor for a lens of focal_mm at f-number N focused at
// focus_mm, for a point at object_mm, in the object-side form that does not cancel:
//   C = (f^2 / N) |z_o - s| / (z_o (s - f)).
// focus_mm and object_mm may be kInfinity. object == focus -> exactly 0.
// object == f -> A (rays leave the lens parallel). object < f or focus <= f ->
// kErrNoRealImage.
Result<double> circle_of_confusion_mm(double focal_mm, double f_number, double focus_mm,
                                      double object_mm);

// C in pixels for a pixel pitch in micrometres.
Result<double> circle_of_confusion_px(double coc_mm, double pixel_pitch_um);

// Airy disk diameter (to the first dark ring) 2.44 lambda N, in micrometres.
Result<double> airy_diameter_um(double f_number, double wavelength_nm = 550.0);

// Hyperfocal distance H = f^2 / (N c) + f.
Result<double> hyperfocal_mm(double focal_mm, double f_number, double coc_mm);

// Depth of field for the acceptable CoC c. far_mm and total_mm are kInfinity when the
// focus is at or beyond the hyperfocal distance; focus_mm may be kInfinity (near = H - f).
// near_mm is never less than focal_mm: if the aperture f/N is smaller than c, everything
// from f on is acceptably sharp and the near limit is f. focus_mm <= f: kErrNoRealImage.
struct DepthOfField {
  double near_mm;
  double far_mm;
  double hyperfocal_mm;
  double total_mm;
};
Result<DepthOfField> depth_of_field(double focal_mm, double f_number, double focus_mm,
                                    double coc_mm);

}  // namespace camlab::optics
