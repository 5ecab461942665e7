#include "device/v4l2/v4l2_control_names.h"

#include <linux/videodev2.h>

#include <cctype>

namespace camlab::device {

std::string control_name_from_label(const std::string& label) {
  std::string name;
  bool pending_separator = false;
  for (unsigned char c : label) {
    if (std::isalnum(c)) {
      if (pending_separator && !name.empty()) name += '_';
      pending_separator = false;
      name += static_cast<char>(std::tolower(c));
    } else {
      pending_separator = true;
    }
  }
  return name;
}

std::string control_unit(uint32_t id) {
  switch (id) {
    case V4L2_CID_EXPOSURE_ABSOLUTE:
      return "100 us";
    case V4L2_CID_FOCUS_ABSOLUTE:
    case V4L2_CID_FOCUS_RELATIVE:
      return "focus steps (larger = closer)";
    case V4L2_CID_IRIS_ABSOLUTE:
      return "iris steps (larger = wider)";
    case V4L2_CID_ZOOM_ABSOLUTE:
      return "zoom steps";
    case V4L2_CID_GAIN:
    case V4L2_CID_ANALOGUE_GAIN:
      return "gain units (driver-defined, linear)";
    case V4L2_CID_PAN_ABSOLUTE:
    case V4L2_CID_TILT_ABSOLUTE:
      return "arc seconds";
    default:
      return "";
  }
}

}  // namespace camlab::device
