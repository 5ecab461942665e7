// A device::Frame over bytes a test packed itself, as a driver would hand it out.
#pragma once

#include <cstdint>
#include <vector>

#include "device/camera.h"

namespace camlab::capture {

inline device::Frame frame_over(std::vector<uint8_t>& bytes) {
  device::Frame frame;
  frame.data = bytes.data();
  frame.size = bytes.size();
  return frame;
}

}  // namespace camlab::capture
