// The common sensor formats (docs/physics.md) and crop factors relative to full frame.
#include <array>
#include <cctype>
#include <cmath>
#include <span>
#include <string>
#include <string_view>

#include "optics/optics.h"

namespace camlab::optics {

namespace {

// Width x height in mm as commonly tabulated, except full frame: tables print
// 36 x 23.9, but crop factors and the FOV figures everyone quotes (17 mm -> 103.7 deg)
// use the nominal 36 x 24, the same as kFullFrameDiagonal_mm.
constexpr std::array<SensorFormat, 9> kSensorFormats = {{
    {"medium-format", "Medium Format", 53.7, 40.2},
    {"full-frame", "Full Frame", 36.0, 24.0},
    {"aps-h", "APS-H", 27.9, 18.6},
    {"aps-c", "APS-C", 23.6, 15.8},
    {"four-thirds", "4/3", 17.3, 13.0},
    {"1in", "1\"", 13.2, 8.8},
    {"1/1.63in", "1/1.63\"", 8.38, 5.59},
    {"1/2.3in", "1/2.3\"", 6.16, 4.62},
    {"1/3.2in", "1/3.2\"", 4.54, 3.42},
}};

// Spellings accepted besides each format's name and label, after normalise() below
// (which already maps "aps-c", "APS C", "1 inch", "1/2.3\"" and the like).
struct Alias {
  std::string_view spelling;
  std::string_view name;
};
constexpr std::array<Alias, 14> kAliases = {{
    {"medium", "medium-format"},
    {"mf", "medium-format"},
    {"ff", "full-frame"},
    {"35mm", "full-frame"},
    {"135", "full-frame"},
    {"fx", "full-frame"},
    {"dx", "aps-c"},
    {"m43", "four-thirds"},
    {"mft", "four-thirds"},
    {"m4/3", "four-thirds"},
    {"micro4/3", "four-thirds"},
    {"microfourthirds", "four-thirds"},
    {"oneinch", "1in"},
    {"1.0", "1in"},
}};

// Lower case without spaces, dashes, underscores, quotes and a trailing "in"/"inch"
// after a digit, so "Full Frame", "full_frame", "1\"", "1 inch" and "1/2.3in" all match.
std::string normalise(std::string_view name) {
  std::string out;
  for (const char c : name) {
    if (c == ' ' || c == '-' || c == '_' || c == '"' || c == '\'') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  for (const std::string_view suffix : {std::string_view("inch"), std::string_view("in")}) {
    if (out.size() > suffix.size() && out.ends_with(suffix) &&
        std::isdigit(static_cast<unsigned char>(out[out.size() - suffix.size() - 1]))) {
      out.resize(out.size() - suffix.size());
      break;
    }
  }
  return out;
}

}  // namespace

std::span<const SensorFormat> sensor_formats() { return kSensorFormats; }

Result<SensorFormat> find_sensor_format(std::string_view name) {
  const std::string key = normalise(name);
  std::string_view canonical;
  for (const SensorFormat& format : kSensorFormats) {
    if (normalise(format.name) == key || normalise(format.label) == key) {
      canonical = format.name;
    }
  }
  for (const Alias& alias : kAliases) {
    if (alias.spelling == key) canonical = alias.name;
  }
  for (const SensorFormat& format : kSensorFormats) {
    if (!key.empty() && format.name == canonical) return format;
  }
  std::string known;
  for (const SensorFormat& format : kSensorFormats) {
    known += (known.empty() ? "" : ", ") + std::string(format.name);
  }
  return make_error(kErrUnknownSensor, "unknown sensor format \"" + std::string(name) +
                                           "\": known formats are " + known);
}

double diagonal_mm(double width_mm, double height_mm) { return std::hypot(width_mm, height_mm); }

Result<double> crop_factor(double sensor_width_mm, double sensor_height_mm) {
  if (auto s = detail::require_positive_finite("sensor_width_mm", sensor_width_mm); !s) {
    return s.error();
  }
  if (auto s = detail::require_positive_finite("sensor_height_mm", sensor_height_mm); !s) {
    return s.error();
  }
  const double crop = kFullFrameDiagonal_mm / diagonal_mm(sensor_width_mm, sensor_height_mm);
  if (auto s = detail::require_finite_result("crop factor", crop); !s) return s.error();
  return crop;
}

}  // namespace camlab::optics
