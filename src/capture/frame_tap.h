// A tap on the frames a capture dequeues, for a viewer beside the capture (camlabd's live
// view): the runner offers every frame it dequeues, kept or not, before the buffer goes
// back to the driver. The tap decides at once whether it wants this one (a viewer's
// frame-rate cap) and copies what it needs; the capture's frame selection never depends
// on it.
//
// Called on the capture's thread (the camera's worker), between dequeue and requeue: an
// implementation must return quickly (a copy at most, never an encode or a lock held by a
// slow reader), since the driver is one buffer short meanwhile.
#pragma once

#include "device/camera.h"

namespace camlab::capture {

class FrameTap {
 public:
  virtual ~FrameTap() = default;
  // `frame` is borrowed for the call only.
  virtual void offer(const device::Frame& frame, const device::StreamFormat& format) = 0;
};

}  // namespace camlab::capture
