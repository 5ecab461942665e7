#include "device/libcamera/libcamera_controls.h"

#include <libcamera/control_ids.h>
#include <libcamera/formats.h>

#include <algorithm>
#include <cctype>
#include <cmath>

namespace camlab::device::libcamera_backend {

namespace {

constexpr double kMilli = 1e-3;  // float controls travel as integer thousandths

// A scalar ControlValue as a double in libcamera's own unit.
double as_double(const libcamera::ControlValue& value) {
  if (value.isNone() || value.isArray()) return 0;
  switch (value.type()) {
    case libcamera::ControlTypeBool:
      return value.get<bool>() ? 1 : 0;
    case libcamera::ControlTypeByte:
      return value.get<uint8_t>();
    case libcamera::ControlTypeInteger32:
      return value.get<int32_t>();
    case libcamera::ControlTypeInteger64:
      return static_cast<double>(value.get<int64_t>());
    case libcamera::ControlTypeFloat:
      return value.get<float>();
    default:
      return 0;
  }
}

// Controls whose values are arrays though their ids name a scalar type: a single
// integer cannot set them.
bool is_array_control(const libcamera::ControlId& id) {
  switch (id.id()) {
    case libcamera::controls::FRAME_DURATION_LIMITS:
    case libcamera::controls::COLOUR_GAINS:
    case libcamera::controls::COLOUR_CORRECTION_MATRIX:
    case libcamera::controls::SENSOR_BLACK_LEVELS:
      return true;
    default:
      return false;
  }
}

std::string unit_of(const libcamera::ControlId& id, double scale) {
  if (id.id() == libcamera::controls::EXPOSURE_TIME) return scale == 100 ? "100 us" : "us";
  if (id.id() == libcamera::controls::LENS_POSITION) return "1/1000 dioptre";
  if (id.id() == libcamera::controls::ANALOGUE_GAIN) return "1/1000";
  if (id.type() == libcamera::ControlTypeFloat) return "1/1000";
  return "";
}

}  // namespace

std::string snake_case(const std::string& camel) {
  std::string out;
  for (size_t i = 0; i < camel.size(); ++i) {
    const auto c = static_cast<unsigned char>(camel[i]);
    // A word starts at an upper-case letter that follows a lower-case one or a digit,
    // or that begins a new word after an acronym ("AeEnable" -> "ae_enable").
    if (std::isupper(c) && i > 0 &&
        (std::islower(static_cast<unsigned char>(camel[i - 1])) ||
         std::isdigit(static_cast<unsigned char>(camel[i - 1])) ||
         (i + 1 < camel.size() && std::islower(static_cast<unsigned char>(camel[i + 1])) &&
          std::isupper(static_cast<unsigned char>(camel[i - 1])))))
      out += '_';
    out += static_cast<char>(std::tolower(c));
  }
  return out;
}

std::vector<ControlBinding> bind_controls(const libcamera::ControlInfoMap& controls) {
  std::vector<ControlBinding> bindings;
  auto bind = [&](const libcamera::ControlId* id, const libcamera::ControlInfo& info,
                  const std::string& name, double scale) {
    ControlBinding b;
    b.id = id;
    b.scale = scale;
    b.info.id = id->id();
    b.info.name = name;
    b.info.label = id->name();
    switch (id->type()) {
      case libcamera::ControlTypeBool:
        b.info.type = ControlType::kBoolean;
        break;
      case libcamera::ControlTypeInteger64:
        b.info.type = ControlType::kInteger64;
        break;
      default:
        b.info.type = ControlType::kInteger;
        break;
    }
    // Ranges in camlab units, rounded inwards so every listed value is settable.
    b.info.minimum = static_cast<int64_t>(std::ceil(as_double(info.min()) / scale - 1e-9));
    b.info.maximum = static_cast<int64_t>(std::floor(as_double(info.max()) / scale + 1e-9));
    b.info.default_value = std::llround(as_double(info.def()) / scale);
    b.info.current = b.info.default_value;
    b.info.step = 1;
    b.info.unit = unit_of(*id, scale);
    bindings.push_back(std::move(b));
  };
  for (const auto& [id, info] : controls) {
    if (is_array_control(*id) || info.min().isArray()) continue;
    switch (id->type()) {
      case libcamera::ControlTypeBool:
      case libcamera::ControlTypeByte:
      case libcamera::ControlTypeInteger32:
      case libcamera::ControlTypeInteger64:
        bind(id, info, snake_case(id->name()), 1.0);
        break;
      case libcamera::ControlTypeFloat:
        bind(id, info, snake_case(id->name()), kMilli);
        break;
      default:
        continue;  // arrays of rectangles, sizes, strings: not a scalar range
    }
    if (id->id() == libcamera::controls::EXPOSURE_TIME)
      bind(id, info, "exposure_time_absolute", 100.0);  // the V4L2 name, in its 100 us units
  }
  std::sort(bindings.begin(), bindings.end(), [](const ControlBinding& a, const ControlBinding& b) {
    return a.info.name < b.info.name;
  });
  return bindings;
}

Result<libcamera::ControlValue> to_control_value(const ControlBinding& binding, int64_t value) {
  const ControlInfo& info = binding.info;
  if (value < info.minimum || value > info.maximum)
    return make_error("out_of_range", info.name + " = " + std::to_string(value) + " is outside [" +
                                          std::to_string(info.minimum) + ", " +
                                          std::to_string(info.maximum) + "]" +
                                          (info.unit.empty() ? "" : " " + info.unit));
  const double native = static_cast<double>(value) * binding.scale;
  switch (binding.id->type()) {
    case libcamera::ControlTypeBool:
      return libcamera::ControlValue(value != 0);
    case libcamera::ControlTypeByte:
      return libcamera::ControlValue(static_cast<uint8_t>(value));
    case libcamera::ControlTypeInteger32:
      return libcamera::ControlValue(static_cast<int32_t>(std::llround(native)));
    case libcamera::ControlTypeInteger64:
      return libcamera::ControlValue(static_cast<int64_t>(std::llround(native)));
    case libcamera::ControlTypeFloat:
      return libcamera::ControlValue(static_cast<float>(native));
    default:
      return make_error("unsupported", info.name + " is not a scalar control");
  }
}

int64_t from_control_value(const ControlBinding& binding, const libcamera::ControlValue& value) {
  return std::llround(as_double(value) / binding.scale);
}

void fill_settings(const libcamera::ControlList& metadata, FrameMetadata* meta) {
  if (auto exposure = metadata.get(libcamera::controls::ExposureTime))
    meta->exposure_us = *exposure;
  if (auto gain = metadata.get(libcamera::controls::AnalogueGain)) meta->analogue_gain = *gain;
  if (auto lens = metadata.get(libcamera::controls::LensPosition)) meta->lens_position = *lens;
  if (auto fom = metadata.get(libcamera::controls::FocusFoM)) meta->focus_fom = *fom;
}

std::string fourcc_of(const libcamera::PixelFormat& format) {
  if (format == libcamera::formats::R8) return "GREY";
  const uint32_t code = format.fourcc();
  std::string text(4, ' ');
  for (int i = 0; i < 4; ++i) text[i] = static_cast<char>((code >> (8 * i)) & 0xff);
  return text;
}

libcamera::PixelFormat pixel_format_of(const std::string& fourcc) {
  if (fourcc == "GREY") return libcamera::formats::R8;
  std::string padded = fourcc;
  padded.resize(4, ' ');
  uint32_t code = 0;
  for (int i = 0; i < 4; ++i)
    code |= static_cast<uint32_t>(static_cast<unsigned char>(padded[i])) << (8 * i);
  return libcamera::PixelFormat(code);
}

}  // namespace camlab::device::libcamera_backend
