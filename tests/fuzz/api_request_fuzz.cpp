// camlabd's request bodies (service/api/api_types.h parse_json_object), query strings
// (parse_query, query_number, query_flag) and the capture
// request's validation (src/capture/capture_plan.h plan_capture), which POST
// /v1/cameras/{id}/captures runs before it queues a job. The handlers themselves need a
// running daemon (a job store, camera workers); this is the layer under them that reads
// what a client sent. The camera is a fixed virtual one with the controls camlab plans
// against: exposure, gain, iris with an f-number table, focus.
#include <linux/videodev2.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "capture/capture_plan.h"
#include "service/api/api_types.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using camlab::device::ControlInfo;
using camlab::device::ControlType;

ControlInfo control(uint32_t id, const char* name, int64_t min, int64_t max, int64_t value,
                    ControlType type = ControlType::kInteger) {
  ControlInfo c;
  c.id = id;
  c.name = name;
  c.label = name;
  c.type = type;
  c.minimum = min;
  c.maximum = max;
  c.default_value = c.current = value;
  return c;
}

struct Camera {
  std::vector<ControlInfo> controls;
  std::vector<camlab::device::PixelFormatInfo> formats;
  camlab::capture::CameraTraits traits;
};

const Camera& camera() {
  static const Camera camera = [] {
    Camera c;
    ControlInfo auto_exposure =
        control(V4L2_CID_EXPOSURE_AUTO, "auto_exposure", 0, 3, 3, ControlType::kMenu);
    auto_exposure.menu = {{1, "Manual Mode"}, {3, "Aperture Priority Mode"}};
    c.controls = {
        auto_exposure,
        control(V4L2_CID_EXPOSURE_ABSOLUTE, "exposure_time_absolute", 1, 10000, 100),
        control(V4L2_CID_GAIN, "gain", 100, 1600, 100),
        control(V4L2_CID_IRIS_ABSOLUTE, "iris_absolute", 0, 4, 0),
        control(V4L2_CID_FOCUS_ABSOLUTE, "focus_absolute", 0, 200, 0),
        control(V4L2_CID_FOCUS_AUTO, "focus_automatic_continuous", 0, 1, 0, ControlType::kBoolean)};
    const camlab::device::FrameSizeInfo size{64, 48, {{1, 30}, {1, 10}}};
    c.formats = {{"Y16 ", "16-bit greyscale", {size}},
                 {"GREY", "8-bit greyscale", {size, {32, 24, {{1, 30}}}}},
                 {"MJPG", "Motion-JPEG", {size}}};
    c.traits.sensor_bit_depth = 12;
    c.traits.black_level_dn = 64;
    c.traits.gain_unity = 100;
    c.traits.f_number_by_iris_position = {11.3, 8, 5.6, 4, 2.8};
    c.traits.focal_mm = 8;
    c.traits.focus_extension_mm_per_step = 0.005;
    return c;
  }();
  return camera;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using camlab::fuzz::check;
  const std::string body(reinterpret_cast<const char*>(data), size);
  // Path parameters ({id}) come from the same client: the parser of job and frame ids.
  if (auto id = camlab::service::parse_id(body, "job"); id) check(*id >= 0, "a negative id");
  // And the query string (the live view's fps and width, the histogram's bins): a number
  // accepted is finite and inside its range; a flag is 0 or 1; both else say why.
  const auto query = camlab::service::parse_query(body);
  check(query.size() <= 16, "more query parameters kept than the bound");
  for (const char* name : {"fps", "width", "bins", "wait"}) {
    auto number = camlab::service::query_number(query, name, 0.2, 30, 10);
    if (number)
      check(std::isfinite(*number) && *number >= 0.2 && *number <= 30, "a number out of range");
    else
      camlab::fuzz::check_error(number.error());
  }
  for (const char* name : {"peaking", "clipping"})
    if (auto flag = camlab::service::query_flag(query, name, false); !flag)
      camlab::fuzz::check_error(flag.error());

  auto json = camlab::service::parse_json_object(body);
  if (!json) {
    camlab::fuzz::check_error(json.error());
    return 0;
  }
  check(json->is_object(), "a body that is not an object was accepted");
  const Camera& c = camera();
  auto plan = camlab::capture::plan_capture(*json, c.controls, c.formats, c.traits);
  if (!plan) {
    camlab::fuzz::check_error(plan.error());
    return 0;
  }
  check(!plan->steps.empty(), "a plan without steps");
  check(plan->total_frames() > 0, "a plan without frames");
  return 0;
}
