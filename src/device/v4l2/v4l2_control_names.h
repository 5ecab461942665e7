// Names and units of V4L2 controls, as camera engineers and v4l2-ctl know them.
//
// Reentrant.
#pragma once

#include <cstdint>
#include <string>

namespace camlab::device {

// v4l2-ctl's rule: lower-case the driver's label and join words with '_'
// ("Exposure Time, Absolute" -> "exposure_time_absolute").
std::string control_name_from_label(const std::string& label);

// The unit of a standard control's value, "" when V4L2 defines none.
// exposure_time_absolute -> "100 us".
std::string control_unit(uint32_t id);

}  // namespace camlab::device
