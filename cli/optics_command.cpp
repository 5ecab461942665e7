// `camlab optics ...`: the thin-lens calculator of src/optics on the command line.
// Units on the command line are the ones the option names say (distances in metres,
// focal lengths and CoC in mm, pixels in um); the library works in mm throughout.
// Each subcommand builds one JSON document; the text form prints the same fields, one
// "name value" line each (names carry units), so the two forms never disagree.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "base/format.h"
#include "command_errors.h"
#include "commands.h"
#include "optics/optics.h"

namespace camlab::cli {
namespace {

namespace optics = camlab::optics;
using json = nlohmann::ordered_json;  // fields in the order a reader expects them

constexpr double kMmPerM = 1000.0;

// ---- Parsing and validation at the edge ----------------------------------------------

std::optional<double> parse_number(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);  // also reads "inf", "nan"
  if (text.empty() || end != text.c_str() + text.size()) return std::nullopt;
  return value;
}

// CLI11's PositiveNumber lets NaN and infinity through and prints DBL_MAX in full; this
// says what is allowed, in the option's unit. `allow_infinity` for distances.
CLI::Validator positive(const std::string& unit, bool allow_infinity = false) {
  return CLI::Validator(
      [unit, allow_infinity](std::string& input) -> std::string {
        const auto value = parse_number(input);
        if (value && *value > 0.0 && (allow_infinity || std::isfinite(*value))) return {};
        return std::string(allow_infinity ? "must be > 0 or inf" : "must be finite and > 0") +
               " (" + unit + "), got '" + input + "'";
      },
      allow_infinity ? "> 0 or inf" : "> 0", allow_infinity ? "DISTANCE" : "POSITIVE");
}

// "1/125", "0.5", "2", "1/4s": an exposure time in seconds.
std::optional<double> parse_shutter_s(std::string text) {
  if (!text.empty() && (text.back() == 's' || text.back() == 'S')) text.pop_back();
  const auto slash = text.find('/');
  std::optional<double> value = parse_number(text.substr(0, slash));
  if (value && slash != std::string::npos) {
    const auto denominator = parse_number(text.substr(slash + 1));
    value = denominator ? std::optional(*value / *denominator) : std::nullopt;
  }
  if (!value || !(*value > 0.0 && std::isfinite(*value))) return std::nullopt;
  return value;
}

// ---- Reporting -------------------------------------------------------------------------

// A distance given in metres, to point at it in errors that the library reports in mm.
struct MetreOption {
  std::string_view flag;
  std::string_view library_name;
  double value_m;
};

struct Context {
  std::string_view subcommand;
  bool json = false;
  std::vector<MetreOption> metres;
};

// Ends the command with the error, as every camlab subcommand does (cli/command_errors.h).
// The library speaks of millimetres (focus_mm = 40); the message also names the flag the
// user gave in metres, so that the value can be found on the command line.
[[noreturn]] void fail(const Context& context, const Error& error) {
  std::string message = error.message;
  for (const MetreOption& option : context.metres) {
    if (message.find(std::string(option.library_name) + " =") != std::string::npos) {
      message +=
          " (from " + std::string(option.flag) + " " + format_significant(option.value_m) + ")";
    }
  }
  CommandErrors("camlab optics " + std::string(context.subcommand), context.json)
      .fail(make_error(error.code, message));
}

Error invalid(std::string message) {
  return make_error(optics::kErrInvalidArgument, std::move(message));
}

template <class T>
T value_or_fail(const Context& context, Result<T> result) {
  if (!result) fail(context, result.error());
  return std::move(result).value();
}

// Infinity is JSON null (JSON has no infinity); the library never returns NaN.
json metres_or_null(double distance_mm) {
  return std::isinf(distance_mm) ? json(nullptr) : json(distance_mm / kMmPerM);
}

// "1/125" below a second, "2 s" above: how cameras show a shutter time.
std::string format_shutter(double exposure_s) {
  if (exposure_s >= 1.0) return format_significant(exposure_s, 3) + " s";
  const double reciprocal = 1.0 / exposure_s;
  return "1/" + (reciprocal >= 10.0 ? format_printf("%.0f", reciprocal)
                                    : format_significant(reciprocal, 2));
}

std::string text_of(const json& value) {
  if (value.is_null()) return "inf";  // the only null this command writes
  if (value.is_boolean()) return value.get<bool>() ? "yes" : "no";
  if (value.is_number()) return format_significant(value.get<double>());
  if (value.is_string()) return value.get<std::string>();
  return value.dump();
}

std::string padded(std::string text, std::size_t width) {
  text.resize(std::max(text.size() + 1, width), ' ');
  return text;
}

// Text form: nested objects as dotted names, arrays of objects as a table.
void print_text(const json& value, const std::string& name) {
  if (value.is_object()) {
    for (const auto& [key, child] : value.items()) {
      print_text(child, name.empty() ? key : name + "." + key);
    }
  } else if (value.is_array() && !value.empty() && value.front().is_object()) {
    std::string header = name + ":\n ";
    for (const auto& [key, child] : value.front().items()) header += " " + padded(key, 15);
    const auto print_trimmed = [](std::string line) {
      std::cout << line.erase(line.find_last_not_of(' ') + 1) << "\n";
    };
    print_trimmed(header);
    for (const json& row : value) {
      std::string line = " ";
      for (const auto& [key, child] : row.items()) line += " " + padded(text_of(child), 15);
      print_trimmed(line);
    }
  } else {
    std::cout << padded(name, 24) << text_of(value) << "\n";
  }
}

void emit(const Context& context, const json& document) {
  if (context.json) {
    std::cout << document.dump(2) << "\n";
  } else {
    print_text(document, "");
  }
}

// ---- Options shared by the subcommands, with units and ranges --------------------------

CLI::App* add_subcommand(CLI::App& parent, const std::string& name, const std::string& description,
                         bool& json_flag) {
  CLI::App* sub = parent.add_subcommand(name, description);
  sub->add_flag("--json", json_flag, "Print one JSON object (infinite distances as null)");
  return sub;
}
void add_focal(CLI::App& sub, double& focal_mm) {
  sub.add_option("--focal-mm", focal_mm, "Focal length in mm (finite, > 0)")
      ->required()
      ->check(positive("mm"));
}
void add_f_number(CLI::App& sub, double& f_number) {
  sub.add_option("--f-number", f_number, "f-number N = focal length / aperture (finite, > 0)")
      ->required()
      ->check(positive("f-number"));
}
template <class T>
CLI::Option* add_distance(CLI::App& sub, const std::string& flag, T& value_m,
                          const std::string& what) {
  return sub.add_option(flag, value_m, what + ", in metres from the lens (> 0, or inf)")
      ->check(positive("m", true));
}

// ---- fov -------------------------------------------------------------------------------

struct FovOptions {
  double focal_mm = 0.0;
  std::string sensor_name, sensor_size_mm;
  bool json = false;
};

optics::SensorFormat resolve_sensor(const Context& context, const FovOptions& options) {
  if (!options.sensor_name.empty()) {
    return value_or_fail(context, optics::find_sensor_format(options.sensor_name));
  }
  const std::string& text = options.sensor_size_mm;
  if (text.empty()) fail(context, invalid("give --sensor NAME or --sensor-mm WIDTHxHEIGHT"));
  const auto x = text.find_first_of("xX*");
  std::optional<double> width_mm, height_mm;
  if (x != std::string::npos) {
    width_mm = parse_number(text.substr(0, x));
    height_mm = parse_number(text.substr(x + 1));
  }
  if (!width_mm || !height_mm) {
    fail(context,
         invalid("--sensor-mm must be WIDTHxHEIGHT in mm, e.g. 36x24; got '" + text + "'"));
  }
  return optics::SensorFormat{"custom", "custom", *width_mm, *height_mm};
}

void run_fov(const FovOptions& options) {
  const Context context{"fov", options.json, {}};
  const optics::SensorFormat sensor = resolve_sensor(context, options);
  const double f = options.focal_mm, width = sensor.width_mm, height = sensor.height_mm;
  const auto fov = value_or_fail(context, optics::field_of_view(f, width, height));
  emit(context, {{"focal_mm", f},
                 {"sensor",
                  {{"name", sensor.name},
                   {"label", sensor.label},
                   {"width_mm", width},
                   {"height_mm", height},
                   {"diagonal_mm", optics::diagonal_mm(width, height)}}},
                 {"hfov_deg", fov.horizontal_deg},
                 {"vfov_deg", fov.vertical_deg},
                 {"dfov_deg", fov.diagonal_deg},
                 {"crop_factor", value_or_fail(context, optics::crop_factor(width, height))},
                 {"equivalent_focal_mm",
                  value_or_fail(context, optics::equivalent_focal_mm(f, width, height))}});
}

void register_fov(CLI::App& parent) {
  auto options = std::make_shared<FovOptions>();
  CLI::App* sub = add_subcommand(
      parent, "fov",
      "Field of view 2 atan(d / 2f) across the sensor's width, height and diagonal "
      "(rectilinear lens focused at infinity); crop factor and 35-mm equivalent focal length.",
      options->json);
  add_focal(*sub, options->focal_mm);
  std::string names;
  for (const optics::SensorFormat& format : optics::sensor_formats()) {
    names += (names.empty() ? "" : ", ") + std::string(format.name);
  }
  CLI::Option* by_name = sub->add_option("--sensor", options->sensor_name,
                                         "Sensor format: " + names + " (or ff, apsc, m43, ...)");
  CLI::Option* by_size = sub->add_option("--sensor-mm", options->sensor_size_mm,
                                         "Sensor size WIDTHxHEIGHT in mm, e.g. 36x24");
  by_name->excludes(by_size);
  sub->callback([options] { run_fov(*options); });
}

// ---- dof and coc -----------------------------------------------------------------------

struct DofOptions {
  double focal_mm = 0.0, f_number = 0.0, focus_m = 0.0, coc_mm = 0.0;
  bool json = false;
};

void run_dof(const DofOptions& options) {
  const Context context{"dof", options.json, {{"--focus-m", "focus_mm", options.focus_m}}};
  const double focus_mm = options.focus_m * kMmPerM;
  const auto dof = value_or_fail(context, optics::depth_of_field(options.focal_mm, options.f_number,
                                                                 focus_mm, options.coc_mm));
  emit(context, {{"focal_mm", options.focal_mm},
                 {"f_number", options.f_number},
                 {"focus_m", metres_or_null(focus_mm)},
                 {"coc_mm", options.coc_mm},
                 {"near_m", metres_or_null(dof.near_mm)},
                 {"far_m", metres_or_null(dof.far_mm)},
                 {"hyperfocal_m", metres_or_null(dof.hyperfocal_mm)},
                 {"total_m", metres_or_null(dof.total_mm)}});
}

void register_dof(CLI::App& parent) {
  auto options = std::make_shared<DofOptions>();
  CLI::App* sub = add_subcommand(
      parent, "dof",
      "Depth of field for an acceptable circle of confusion c: near and far limits and the "
      "hyperfocal distance H = f^2 / (N c) + f. Focused at or beyond H, far is infinite.",
      options->json);
  add_focal(*sub, options->focal_mm);
  add_f_number(*sub, options->f_number);
  add_distance(*sub, "--focus-m", options->focus_m, "Focus distance (beyond the focal length)")
      ->required();
  sub->add_option("--coc-mm", options->coc_mm,
                  "Acceptable circle of confusion in mm (finite, > 0; 0.03 is usual for full "
                  "frame)")
      ->required()
      ->check(positive("mm"));
  sub->callback([options] { run_dof(*options); });
}

struct CocOptions {
  double focal_mm = 0.0, f_number = 0.0, focus_m = 0.0, object_m = 0.0;
  std::optional<double> pixel_um;
  double wavelength_nm = 550.0;
  bool json = false;
};

void run_coc(const CocOptions& options) {
  const Context context{
      "coc",
      options.json,
      {{"--focus-m", "focus_mm", options.focus_m}, {"--object-m", "object_mm", options.object_m}}};
  const double focus_mm = options.focus_m * kMmPerM, object_mm = options.object_m * kMmPerM;
  const double coc_mm = value_or_fail(
      context,
      optics::circle_of_confusion_mm(options.focal_mm, options.f_number, focus_mm, object_mm));
  const double airy_um =
      value_or_fail(context, optics::airy_diameter_um(options.f_number, options.wavelength_nm));
  json document{{"focal_mm", options.focal_mm},
                {"f_number", options.f_number},
                {"focus_m", metres_or_null(focus_mm)},
                {"object_m", metres_or_null(object_mm)},
                {"coc_mm", coc_mm}};
  if (options.pixel_um) {
    document["pixel_um"] = *options.pixel_um;
    document["coc_px"] =
        value_or_fail(context, optics::circle_of_confusion_px(coc_mm, *options.pixel_um));
  }
  document["wavelength_nm"] = options.wavelength_nm;
  document["airy_diameter_um"] = airy_um;
  // Below the Airy disk, diffraction rather than defocus sets the blur.
  document["below_diffraction"] = coc_mm * 1000.0 < airy_um;
  emit(context, document);
}

void register_coc(CLI::App& parent) {
  auto options = std::make_shared<CocOptions>();
  CLI::App* sub = add_subcommand(
      parent, "coc",
      "Blur-circle diameter on the sensor for a point at --object-m when focused at --focus-m, "
      "C = (f^2 / N) |z_o - s| / (z_o (s - f)), against the Airy disk 2.44 lambda N.",
      options->json);
  add_focal(*sub, options->focal_mm);
  add_f_number(*sub, options->f_number);
  add_distance(*sub, "--focus-m", options->focus_m, "Focus distance (beyond the focal length)")
      ->required();
  add_distance(*sub, "--object-m", options->object_m, "Object distance (at least the focal length)")
      ->required();
  sub->add_option("--pixel-um", options->pixel_um, "Pixel pitch in um (finite, > 0): adds coc_px")
      ->check(positive("um"));
  sub->add_option("--wavelength-nm", options->wavelength_nm,
                  "Wavelength for the Airy disk in nm (finite, > 0)")
      ->capture_default_str()
      ->check(positive("nm"));
  sub->callback([options] { run_coc(*options); });
}

// ---- exposure --------------------------------------------------------------------------

struct ExposureOptions {
  double f_number = 0.0, iso = 100.0;
  std::optional<double> exposure_us, to_f_number, to_iso;
  std::string shutter;
  bool json = false;
};

json exposure_entry(double f_number, double exposure_s) {
  return {{"f_number", f_number},
          {"shutter", format_shutter(exposure_s)},
          {"exposure_s", exposure_s},
          {"exposure_us", exposure_s * 1e6}};
}

void run_exposure(const ExposureOptions& options) {
  const Context context{"exposure", options.json, {}};
  std::optional<double> exposure_s;
  if (options.exposure_us) {
    exposure_s = *options.exposure_us * 1e-6;
  } else if (options.shutter.empty()) {
    fail(context, invalid("give --exposure-us T or --shutter 1/125"));
  } else if (!(exposure_s = parse_shutter_s(options.shutter))) {
    fail(context, invalid("--shutter must be a time in seconds > 0 such as 1/125, 0.5 or 2; "
                          "got '" +
                          options.shutter + "'"));
  }
  const double n = options.f_number, t_s = *exposure_s;
  const double ev = value_or_fail(context, optics::exposure_value(n, t_s));
  const double gain = value_or_fail(context, optics::gain_from_iso(options.iso));
  const double target_iso = options.to_iso.value_or(options.iso);
  const double target_gain = value_or_fail(context, optics::gain_from_iso(target_iso));
  const auto equivalent_s = [&](double new_n) {
    return value_or_fail(context, optics::equivalent_exposure_s(t_s, n, gain, new_n, target_gain));
  };
  json document{{"f_number", n},
                {"shutter", format_shutter(t_s)},
                {"exposure_s", t_s},
                {"exposure_us", t_s * 1e6},
                {"iso", options.iso},
                {"ev", ev},
                // EV100 describes the scene: the settings' EV less the stops the gain adds.
                {"ev100", ev - std::log2(gain)},
                {"relative_exposure", value_or_fail(context, optics::relative_exposure(n, t_s))},
                {"target_iso", target_iso}};
  if (options.to_f_number || options.to_iso) {
    const double new_n = options.to_f_number.value_or(n);
    document["equivalent"] = exposure_entry(new_n, equivalent_s(new_n));
  }
  json table = json::array();
  for (const optics::FStop& stop : optics::f_stop_series(optics::StopIncrement::kFull)) {
    // The time for the exact stop: the engraved f/11 is really f/11.31.
    table.push_back(exposure_entry(stop.marked, equivalent_s(stop.exact)));
    table.back()["f_number_exact"] = stop.exact;
  }
  document["equivalents"] = table;
  emit(context, document);
}

void register_exposure(CLI::App& parent) {
  auto options = std::make_shared<ExposureOptions>();
  CLI::App* sub = add_subcommand(
      parent, "exposure",
      "Exposure value EV = log2(N^2 / T), EV100, light gathered T / N^2, and the times giving "
      "the same brightness at every full stop f/1 to f/32 (gain linear in ISO).",
      options->json);
  add_f_number(*sub, options->f_number);
  CLI::Option* time_us = sub->add_option("--exposure-us", options->exposure_us,
                                         "Exposure time in microseconds (finite, > 0)")
                             ->check(positive("us"));
  CLI::Option* shutter = sub->add_option(
      "--shutter", options->shutter, "Exposure time in seconds as cameras show it: 1/125, 0.5, 2");
  time_us->excludes(shutter);
  sub->add_option("--iso", options->iso, "Sensitivity in use (finite, > 0)")
      ->capture_default_str()
      ->check(positive("ISO"));
  sub->add_option("--to-f-number", options->to_f_number,
                  "Also give the one equivalent time at this f-number (finite, > 0)")
      ->check(positive("f-number"));
  sub->add_option("--to-iso", options->to_iso,
                  "Sensitivity of the equivalents (finite, > 0; default --iso)")
      ->check(positive("ISO"));
  sub->callback([options] { run_exposure(*options); });
}

// ---- lens ------------------------------------------------------------------------------

struct LensOptions {
  double focal_mm = 0.0;
  std::optional<double> object_m, lens_to_sensor_mm;
  bool json = false;
};

void run_lens(const LensOptions& options) {
  const Context context{
      "lens", options.json, {{"--object-m", "object_mm", options.object_m.value_or(0.0)}}};
  const double f = options.focal_mm;
  double object_mm = 0.0, image_mm = 0.0;
  if (options.object_m) {
    object_mm = *options.object_m * kMmPerM;
    image_mm = value_or_fail(context, optics::image_distance_mm(f, object_mm));
  } else if (options.lens_to_sensor_mm) {
    image_mm = *options.lens_to_sensor_mm;
    object_mm = value_or_fail(context, optics::focus_distance_mm(f, image_mm));
  } else {
    fail(context, invalid("give --object-m Z or --lens-to-sensor-mm D"));
  }
  emit(context,
       {{"focal_mm", f},
        {options.object_m ? "object_m" : "focus_distance_m", metres_or_null(object_mm)},
        {"image_distance_mm", image_mm},
        {"lens_to_sensor_mm", image_mm},
        // How far the lens sits beyond its infinity position: what focusing closer costs.
        {"extension_mm", image_mm - f},
        // With the sensor at f the focus is at infinity, where the magnification is 0.
        {"magnification", std::isinf(object_mm)
                              ? 0.0
                              : value_or_fail(context, optics::magnification(f, object_mm))}});
}

void register_lens(CLI::App& parent) {
  auto options = std::make_shared<LensOptions>();
  CLI::App* sub = add_subcommand(
      parent, "lens",
      "Thin-lens equation 1/f = 1/z_i + 1/z_o: image distance and magnification for an "
      "object, or the focus distance for a lens-to-sensor distance.",
      options->json);
  add_focal(*sub, options->focal_mm);
  CLI::Option* object = add_distance(*sub, "--object-m", options->object_m,
                                     "Object distance (beyond the focal length)");
  CLI::Option* sensor = sub->add_option("--lens-to-sensor-mm", options->lens_to_sensor_mm,
                                        "Lens-to-sensor distance in mm (finite, >= focal length)")
                            ->check(positive("mm"));
  object->excludes(sensor);
  sub->callback([options] { run_lens(*options); });
}

// ---- stops -----------------------------------------------------------------------------

struct StopsOptions {
  std::string increment = "full";
  double max_f_number = 32.0;
  bool json = false;
};

void run_stops(const StopsOptions& options) {
  const auto increment = options.increment == "third"  ? optics::StopIncrement::kThird
                         : options.increment == "half" ? optics::StopIncrement::kHalf
                                                       : optics::StopIncrement::kFull;
  json stops = json::array();
  for (const optics::FStop& stop : optics::f_stop_series(increment, options.max_f_number)) {
    stops.push_back({{"marked", stop.marked}, {"exact", stop.exact}});
  }
  emit(Context{"stops", options.json, {}}, {{"increment", options.increment}, {"stops", stops}});
}

void register_stops(CLI::App& parent) {
  auto options = std::make_shared<StopsOptions>();
  CLI::App* sub = add_subcommand(
      parent, "stops",
      "The f-stop series from f/1: exact sqrt(2)^(k/n) and the value lenses engrave.",
      options->json);
  sub->add_option("--increment", options->increment, "Step between stops: full, half or third")
      ->capture_default_str()
      ->check(CLI::IsMember({"full", "half", "third"}));
  sub->add_option("--max-f-number", options->max_f_number,
                  "Last f-number of the series (1 to 1024)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1024.0));
  sub->callback([options] { run_stops(*options); });
}

}  // namespace

void register_optics_command(CLI::App& app) {
  CLI::App* optics_app = app.add_subcommand(
      "optics",
      "Thin-lens optics: field of view, depth of field, circle of confusion, exposure, the "
      "lens equation and f-stops. Distances in metres (inf where it makes sense), focal "
      "lengths and CoC in mm, pixel pitch in um.");
  optics_app->require_subcommand(1);
  register_fov(*optics_app);
  register_dof(*optics_app);
  register_coc(*optics_app);
  register_exposure(*optics_app);
  register_lens(*optics_app);
  register_stops(*optics_app);
}

}  // namespace camlab::cli
