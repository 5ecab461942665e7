// f-stop series, exposure value, and trading aperture, time and gain for one another.
// H = T x E with the irradiance E ~ 1/N^2; gain (ISO) scales the signal linearly.
#include <array>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "optics/optics.h"

namespace camlab::optics {

namespace {

// What lenses and cameras engrave, f/1 to f/32. The exact values are sqrt(2)^(k/n);
// the marks round them by convention (f/11 is 11.31, f/22 is 22.6, f/5.6 is 5.66).
constexpr std::array<double, 11> kMarkedFull = {1, 1.4, 2, 2.8, 4, 5.6, 8, 11, 16, 22, 32};
constexpr std::array<double, 21> kMarkedHalf = {1,   1.2, 1.4, 1.7, 2,  2.4, 2.8, 3.3, 4,  4.8, 5.6,
                                                6.7, 8,   9.5, 11,  13, 16,  19,  22,  27, 32};
constexpr std::array<double, 31> kMarkedThird = {
    1,   1.1, 1.2, 1.4, 1.6, 1.8, 2,  2.2, 2.5, 2.8, 3.2, 3.5, 4,  4.5, 5.0, 5.6,
    6.3, 7.1, 8,   9,   10,  11,  13, 14,  16,  18,  20,  22,  25, 29,  32};

std::span<const double> marked_table(StopIncrement increment) {
  switch (increment) {
    case StopIncrement::kFull:
      return kMarkedFull;
    case StopIncrement::kHalf:
      return kMarkedHalf;
    case StopIncrement::kThird:
      return kMarkedThird;
  }
  return {};
}

// Beyond f/32 there is no single convention: two significant digits (45, 64, 91, ...).
double round_to_two_digits(double value) {
  const double scale = std::pow(10.0, std::floor(std::log10(value)) - 1.0);
  return std::round(value / scale) * scale;
}

}  // namespace

std::vector<FStop> f_stop_series(StopIncrement increment, double max_f_number) {
  std::vector<FStop> series;
  const std::span<const double> marked = marked_table(increment);
  // An increment outside the enum or a maximum below f/1 (or NaN) gives no stops.
  if (marked.empty() || !(max_f_number >= 1.0)) return series;
  const int steps_per_stop = static_cast<int>(increment);
  // Bounded: f/1e300 would be ~2000 full stops; nobody needs more than f/1024.
  const double max_checked = std::fmin(max_f_number, 1024.0);
  for (int k = 0;; ++k) {
    // sqrt(2)^(k/n) = 2^(k / 2n): exact powers of two at whole stops.
    const double exact = std::exp2(static_cast<double>(k) / (2.0 * steps_per_stop));
    // Relative tolerance so that a maximum typed as 22.6 or 32 includes that stop.
    if (exact > max_checked * (1.0 + 1e-9)) break;
    const double mark = static_cast<std::size_t>(k) < marked.size()
                            ? marked[static_cast<std::size_t>(k)]
                            : round_to_two_digits(exact);
    series.push_back(FStop{exact, mark});
  }
  return series;
}

Result<double> exposure_value(double f_number, double exposure_s) {
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_finite("exposure_s", exposure_s); !s) {
    return s.error();
  }
  // log2(N^2 / T) as a difference of logs: N^2 / T cannot overflow or underflow.
  return 2.0 * std::log2(f_number) - std::log2(exposure_s);
}

Result<double> relative_exposure(double f_number, double exposure_s) {
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_finite("exposure_s", exposure_s); !s) {
    return s.error();
  }
  const double relative = exposure_s / f_number / f_number;
  if (auto s = detail::require_finite_result("relative exposure", relative); !s) {
    return s.error();
  }
  return relative;
}

Result<double> photometric_exposure_lux_s(double illuminance_lux, double exposure_s) {
  if (auto s = detail::require_positive_finite("illuminance_lux", illuminance_lux); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_finite("exposure_s", exposure_s); !s) {
    return s.error();
  }
  const double exposure_lux_s = illuminance_lux * exposure_s;
  if (auto s = detail::require_finite_result("photometric exposure (lux s)", exposure_lux_s); !s) {
    return s.error();
  }
  return exposure_lux_s;
}

Result<double> equivalent_exposure_s(double exposure_s, double f_number, double gain,
                                     double new_f_number, double new_gain) {
  if (auto s = detail::require_positive_finite("exposure_s", exposure_s); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_finite("f_number", f_number); !s) return s.error();
  if (auto s = detail::require_positive_finite("gain", gain); !s) return s.error();
  if (auto s = detail::require_positive_finite("new_f_number", new_f_number); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_finite("new_gain", new_gain); !s) return s.error();
  // Same signal T g / N^2 before and after. Ratios first, so that the intermediate
  // products stay near 1 for any sensible input.
  const double ratio = new_f_number / f_number;
  const double new_exposure_s = exposure_s * ratio * ratio * (gain / new_gain);
  if (auto s = detail::require_finite_result("equivalent exposure (s)", new_exposure_s); !s) {
    return s.error();
  }
  if (new_exposure_s == 0.0) {
    return make_error(kErrInvalidArgument,
                      "the inputs are too extreme: the equivalent exposure time underflows "
                      "to 0 s");
  }
  return new_exposure_s;
}

Result<double> gain_from_iso(double iso, double base_iso) {
  if (auto s = detail::require_positive_finite("iso", iso); !s) return s.error();
  if (auto s = detail::require_positive_finite("base_iso", base_iso); !s) return s.error();
  const double gain = iso / base_iso;
  if (auto s = detail::require_finite_result("gain", gain); !s) return s.error();
  return gain;
}

}  // namespace camlab::optics
