// How a frame's values relate to light: the transfer function a camera declares for a
// format (V4L2's xfer_func, libcamera's ColorSpace::TransferFunction). A webcam's YUYV and
// MJPEG are gamma-encoded; a measurement that reads them as light is wrong by a curve, so
// capture records which, and the analyses decode or refuse.
//
//   linear  values proportional to light above black (raw sensor data)
//   srgb    IEC 61966-2-1: v = 12.92 L below 0.0031308, else 1.055 L^(1/2.4) - 0.055
//   bt709   ITU-R BT.709's OETF: v = 4.5 L below 0.018, else 1.099 L^0.45 - 0.099
//   other   declared, but none of these (Adobe RGB, SMPTE 240M, PQ, DCI-P3): not decoded
//   unknown the camera declares no colour space (V4L2's colorspace and xfer_func left at
//           DEFAULT, libcamera's StreamConfiguration without one): capture takes a raw
//           format's samples as linear (a sensor's DN), and any processed format's curve
//           as not known, so it is not decoded either. Guessing one (taking it as linear,
//           as camlab once did on libcamera) would give a silently wrong number.
//
// Reentrant: pure functions.
#pragma once

#include <cmath>
#include <optional>
#include <string_view>

namespace camlab {

enum class TransferFunction { kLinear, kSrgb, kBt709, kOther, kUnknown };

constexpr std::string_view name_of(TransferFunction transfer) {
  switch (transfer) {
    case TransferFunction::kLinear:
      return "linear";
    case TransferFunction::kSrgb:
      return "srgb";
    case TransferFunction::kBt709:
      return "bt709";
    case TransferFunction::kOther:
      return "other";
    case TransferFunction::kUnknown:
      return "unknown";
  }
  return "other";
}

inline std::optional<TransferFunction> transfer_function_named(std::string_view name) {
  for (TransferFunction t :
       {TransferFunction::kLinear, TransferFunction::kSrgb, TransferFunction::kBt709,
        TransferFunction::kOther, TransferFunction::kUnknown})
    if (name == name_of(t)) return t;
  return std::nullopt;
}

// Whether decode_to_light inverts `transfer` (linear included).
constexpr bool is_decodable(TransferFunction transfer) {
  return transfer != TransferFunction::kOther && transfer != TransferFunction::kUnknown;
}

// The light L in 0..1 of an encoded value v in 0..1 (values outside are clamped: a
// limited-range code below black or above white carries no more light).
inline double decode_to_light(TransferFunction transfer, double v) {
  v = v < 0 ? 0 : v > 1 ? 1 : v;
  switch (transfer) {
    case TransferFunction::kSrgb:
      return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    case TransferFunction::kBt709:
      return v < 0.081 ? v / 4.5 : std::pow((v + 0.099) / 1.099, 1.0 / 0.45);
    default:
      return v;
  }
}

// The encoded value v in 0..1 of light L in 0..1 (the inverse of decode_to_light).
inline double encode_light(TransferFunction transfer, double light) {
  light = light < 0 ? 0 : light > 1 ? 1 : light;
  switch (transfer) {
    case TransferFunction::kSrgb:
      return light <= 0.0031308 ? 12.92 * light : 1.055 * std::pow(light, 1.0 / 2.4) - 0.055;
    case TransferFunction::kBt709:
      return light < 0.018 ? 4.5 * light : 1.099 * std::pow(light, 0.45) - 0.099;
    default:
      return light;
  }
}

}  // namespace camlab
