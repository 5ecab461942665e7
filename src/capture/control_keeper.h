// Changes a camera's controls for a capture and puts them back afterwards: remembers the
// value of every control it will write, and of the auto mode a manual value switches off
// (exposure_time_absolute -> auto_exposure, focus_absolute -> focus_automatic_continuous),
// before anything changes. It also keeps the values in effect as read back, for sidecars.
//
// Thread-bound (the camera's worker thread).
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::capture {

class ControlKeeper {
 public:
  // Reads the current values (one enumeration) of `to_write`, their auto modes, and the
  // controls sidecars describe (exposure, gain, focus, iris and their modes).
  static Result<ControlKeeper> snapshot(device::Camera& camera,
                                        const std::set<std::string>& to_write);

  // Writes one control and keeps the value the driver applied (read back). Re-reads the
  // auto mode a manual value may have switched off.
  Result<int64_t> write(device::Camera& camera, const std::string& name, int64_t value);

  // Puts back every control written, manual values first and auto modes last (a manual
  // value written after its mode would switch the mode off again). Tries them all; returns
  // the first error.
  Status restore(device::Camera& camera);

  // The values in effect once every write so far has settled, by V4L2 name.
  const std::map<std::string, int64_t>& values() const { return values_; }

 private:
  std::map<std::string, int64_t> values_;
  std::map<std::string, int64_t> originals_;  // of controls written or switched
  std::set<std::string> written_;
};

}  // namespace camlab::capture
