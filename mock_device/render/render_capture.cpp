#include "mock_device/render/render_capture.h"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "base/format.h"
#include "image/capture_folder.h"
#include "image/pixel_format.h"
#include "mock_device/render/frame_truth.h"
#include "optics/optics.h"

namespace camlab::mock {

namespace {

constexpr int kMaxFrames = 100000;

Result<double> parse_number(const std::string& text, const std::string& context) {
  try {
    size_t used = 0;
    const double value = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(value)) throw std::invalid_argument(text);
    return value;
  } catch (const std::exception&) {
    return make_error("invalid_argument", context + ": '" + text + "' is not a number");
  }
}

}  // namespace

namespace {

// The factor between neighbouring values of a geometric step: "stops" (a factor 2 in light:
// sqrt 2 in f-number, 2 in exposure or gain), "half-stops", "third-stops", or "xR" (R > 0,
// any ratio). 0 when `step` is none of these (an additive step).
double geometric_factor(const std::string& parameter, const std::string& step) {
  const double per_stop = parameter == "f_number" ? std::sqrt(2.0) : 2.0;
  if (step == "stops") return per_stop;
  if (step == "half-stops") return std::sqrt(per_stop);
  if (step == "third-stops") return std::cbrt(per_stop);
  if (step.size() > 1 && step[0] == 'x') {
    char* end = nullptr;
    const double ratio = std::strtod(step.c_str() + 1, &end);
    if (*end == '\0' && std::isfinite(ratio) && ratio > 0) return ratio;
  }
  return 0;
}

}  // namespace

Result<Sweep> parse_sweep(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    return make_error("invalid_argument",
                      "sweep '" + text +
                          "' must be name=v1,v2,..., name=start:stop:step (added), or "
                          "name=start:stop:stops | half-stops | third-stops | xRATIO (multiplied)");
  Sweep sweep;
  sweep.parameter = text.substr(0, eq);
  const std::string values = text.substr(eq + 1);
  if (values.find(':') != std::string::npos) {
    std::vector<std::string> fields;
    std::stringstream in(values);
    for (std::string part; std::getline(in, part, ':');) fields.push_back(part);
    if (fields.size() != 3)
      return make_error("invalid_argument", "sweep range '" + values + "' must be start:stop:step");
    double start, stop;
    CAMLAB_ASSIGN(start, parse_number(fields[0], "sweep " + sweep.parameter));
    CAMLAB_ASSIGN(stop, parse_number(fields[1], "sweep " + sweep.parameter));
    if (const double factor = geometric_factor(sweep.parameter, fields[2]); factor > 0) {
      // Multiplied: photographers read an aperture series in stops (f/2, 2.8, 4, ...), where
      // an added step of 1.41421 gives f/2, 3.41, 4.83.
      if (!(start > 0) || factor == 1 || (stop / start > 1) != (factor > 1))
        return make_error("invalid_argument",
                          "sweep range '" + values + "' must start above 0 and step towards stop");
      const double count = std::floor(std::log(stop / start) / std::log(factor) + 1e-9) + 1;
      if (count > kMaxFrames)
        return make_error("out_of_range", "sweep range gives " + std::to_string(count) +
                                              " values; at most " + std::to_string(kMaxFrames));
      for (int i = 0; i < static_cast<int>(count); ++i)
        sweep.values.push_back(start * std::pow(factor, i));
    } else {
      double step;
      CAMLAB_ASSIGN(step, parse_number(fields[2], "sweep " + sweep.parameter + " step"));
      if (step == 0 || (stop - start) / step < 0)
        return make_error(
            "invalid_argument",
            "sweep range '" + values + "' must be start:stop:step with a step towards stop");
      const double count = std::floor((stop - start) / step + 1e-9) + 1;
      if (count > kMaxFrames)
        return make_error("out_of_range", "sweep range gives " + std::to_string(count) +
                                              " values; at most " + std::to_string(kMaxFrames));
      for (int i = 0; i < static_cast<int>(count); ++i) sweep.values.push_back(start + i * step);
    }
  } else {
    std::stringstream in(values);
    for (std::string part; std::getline(in, part, ',');) {
      double v;
      CAMLAB_ASSIGN(v, parse_number(part, "sweep " + sweep.parameter));
      sweep.values.push_back(v);
    }
  }
  if (sweep.values.empty())
    return make_error("invalid_argument", "sweep '" + text + "' has no values");
  return sweep;
}

Status apply_setting(const Renderer& renderer, const std::string& name, double value,
                     RenderSettings* settings) {
  if (name == "exposure_us")
    settings->exposure_us = value;
  else if (name == "gain")
    settings->gain = value;
  else if (name == "f_number")
    settings->f_number = value;
  else if (name == "focus_position") {
    if (value != std::round(value))
      return make_error("invalid_argument", "focus_position must be a whole number of steps, not " +
                                                std::to_string(value));
    settings->focus_position = static_cast<int>(value);
  } else if (name == "focus_m") {
    const LensSpec& lens = renderer.camera().lens;
    auto z_s = optics::lens_to_sensor_mm(lens.focal_mm, value * 1e3);
    if (!z_s)
      return make_error(z_s.error().code,
                        "focus_m = " + std::to_string(value) + ": " + z_s.error().message);
    // The focus motor moves in steps: the nearest step, reported as what is in effect.
    settings->focus_position =
        static_cast<int>(std::lround((*z_s - lens.focal_mm) / lens.focus.extension_mm_per_step));
  } else {
    return make_error(
        "invalid_argument",
        "unknown setting '" + name + "' (exposure_us, gain, f_number, focus_position, focus_m)");
  }
  return renderer.validate(*settings);
}

namespace {

// One swept value; with hold_exposure an f-number brings its exposure time along.
Status apply_swept(const Renderer& renderer, const RenderCaptureRequest& request,
                   const std::string& name, double value, RenderSettings* settings) {
  if (request.hold_exposure && name == "f_number" && request.base.f_number > 0) {
    const double ratio = value / request.base.f_number;
    settings->exposure_us = request.base.exposure_us * ratio * ratio;
  }
  if (Status ok = apply_setting(renderer, name, value, settings); !ok) {
    if (request.hold_exposure && name == "f_number")
      return make_error(ok.error().code,
                        ok.error().message + format_printf(" (exposure %.0f us held for f/%g)",
                                                           settings->exposure_us, value));
    return ok;
  }
  return {};
}

}  // namespace

Result<RenderCaptureSummary> render_capture(Renderer& renderer,
                                            const RenderCaptureRequest& request) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<int> views = request.views;
  if (views.empty())
    for (int v = 0; v < renderer.scene().view_count; ++v) views.push_back(v);
  for (int v : views)
    if (v < 0 || v >= renderer.scene().view_count)
      return make_error("out_of_range", "view " + std::to_string(v) + " is not in 0.." +
                                            std::to_string(renderer.scene().view_count - 1));
  if (request.repeats < 1 || request.repeats > 1000)
    return make_error("out_of_range",
                      "repeats = " + std::to_string(request.repeats) + " is not in [1, 1000]");

  // Every setting is checked before the first frame, so a bad value loses no work.
  std::vector<RenderSettings> settings_list;
  if (request.inner_sweep &&
      (!request.sweep || request.sweep->parameter == request.inner_sweep->parameter))
    return make_error("invalid_argument", "a second sweep (" + request.inner_sweep->parameter +
                                              ") needs a first one of another setting");
  if (request.sweep) {
    std::vector<RenderSettings> outer;
    for (double value : request.sweep->values) {
      RenderSettings s = request.base;
      if (Status ok = apply_swept(renderer, request, request.sweep->parameter, value, &s); !ok)
        return make_error(ok.error().code,
                          "sweep " + request.sweep->parameter + ": " + ok.error().message);
      outer.push_back(s);
    }
    for (const RenderSettings& o : outer) {
      if (!request.inner_sweep) {
        settings_list.push_back(o);
        continue;
      }
      for (double value : request.inner_sweep->values) {
        RenderSettings s = o;
        if (Status ok = apply_swept(renderer, request, request.inner_sweep->parameter, value, &s);
            !ok)
          return make_error(ok.error().code,
                            "sweep " + request.inner_sweep->parameter + ": " + ok.error().message);
        settings_list.push_back(s);
      }
    }
  } else {
    if (Status ok = renderer.validate(request.base); !ok) return ok.error();
    settings_list.push_back(request.base);
  }
  const long total = static_cast<long>(views.size()) * settings_list.size() * request.repeats;
  if (total > kMaxFrames)
    return make_error("out_of_range", "the request renders " + std::to_string(total) +
                                          " frames; at most " + std::to_string(kMaxFrames));

  const CameraSpec& camera = renderer.camera();
  nlohmann::json source = {{"backend", "virtual"},
                           {"camera", camera.name},
                           {"camera_spec", camera.source},
                           {"scene_spec", renderer.scene().source}};
  nlohmann::json parameters = {{"repeats", request.repeats},
                               {"views", views},
                               {"seed", request.options.seed},
                               {"noise", request.options.noise},
                               {"hold_exposure", request.hold_exposure}};
  if (request.sweep)
    parameters["sweep"] = {{"parameter", request.sweep->parameter},
                           {"values", request.sweep->values}};
  if (request.inner_sweep)
    parameters["inner_sweep"] = {{"parameter", request.inner_sweep->parameter},
                                 {"values", request.inner_sweep->values}};
  auto writer = image::CaptureFolderWriter::create(request.out_dir, "render", source, parameters);
  if (!writer) return writer.error();

  bool constant_focus = true;
  for (const auto& s : settings_list)
    constant_focus &= s.focus_position == settings_list[0].focus_position;
  if (constant_focus) {
    const double z_s = camera.lens.focal_mm +
                       settings_list[0].focus_position * camera.lens.focus.extension_mm_per_step;
    if (Status s = writer->add_file("truth.cameramodel",
                                    truth_cameramodel_text(camera, intrinsics_at(camera, z_s)));
        !s)
      return s.error();
  }

  uint64_t sequence = 0;
  for (int view : views) {
    for (size_t k = 0; k < settings_list.size(); ++k) {
      for (int repeat = 0; repeat < request.repeats; ++repeat, ++sequence) {
        RenderOptions options = request.options;
        options.frame_number = sequence;
        auto frame = renderer.render(settings_list[k], view, options);
        if (!frame) return frame.error();
        image::FrameSidecar sidecar;
        sidecar.sequence = sequence;
        // The virtual camera's clock: frames follow each other at the frame interval.
        sidecar.timestamp_ns =
            static_cast<int64_t>(std::llround(sequence * camera.timing.frame_interval_us * 1e3));
        sidecar.clock = "virtual";
        if (camera.sensor.is_colour()) {
          // The raw mosaic, as a Bayer sensor delivers it (SRGGB12 ...).
          sidecar.layout = image::FrameLayout::kMosaic;
          sidecar.cfa_pattern = camera.sensor.cfa;
          sidecar.pixel_format = "S" + camera.sensor.cfa + std::to_string(camera.sensor.bit_depth);
        } else {
          sidecar.pixel_format = std::string(image::mono_pixel_format(camera.sensor.bit_depth));
        }
        sidecar.bit_depth = camera.sensor.bit_depth;
        sidecar.black_level_dn = camera.sensor.black_level_dn;
        sidecar.settings = frame->settings;
        sidecar.labels = {{"view", view}, {"sweep_index", k}, {"repeat", repeat}};
        sidecar.truth = frame->truth;
        if (auto added = writer->add_frame(frame->image, sidecar); !added) return added.error();
        if (request.progress)
          request.progress(static_cast<int>(sequence + 1), static_cast<int>(total), *frame);
      }
    }
  }
  if (Status s = writer->finish(); !s) return s.error();
  RenderCaptureSummary summary;
  summary.frames = static_cast<int>(total);
  summary.out_dir = request.out_dir;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace camlab::mock
