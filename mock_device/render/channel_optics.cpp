#include "mock_device/render/channel_optics.h"

#include <cmath>

#include "mock_device/render/target_surface.h"
#include "optics/optics.h"

namespace camlab::mock {

double channel_image_scale(const CameraSpec& camera, int channel) {
  if (channel < 0 || channel > 2) return 1;
  const double half_diagonal_px = 0.5 * std::hypot(camera.sensor.width_px, camera.sensor.height_px);
  return 1 + camera.lens.lateral_colour_px[static_cast<size_t>(channel)] / half_diagonal_px;
}

Result<ChannelOptics> channel_optics(const CameraSpec& camera, int channel, double f_number,
                                     double lens_to_sensor_mm) {
  ChannelOptics o;
  o.channel = channel;
  o.focal_mm = channel == kGrey ? camera.lens.focal_mm : camera.lens.channel_focal_mm(channel);
  o.aperture_mm = camera.lens.focal_mm / f_number;
  o.lens_to_sensor_mm = lens_to_sensor_mm;
  if (lens_to_sensor_mm >= o.focal_mm) {
    auto s = optics::focus_distance_mm(o.focal_mm, lens_to_sensor_mm);
    if (!s) return s.error();
    o.focus_distance_mm = *s;
  } else {
    // 1/s = 1/f_c - 1/z_s < 0: a virtual plane of focus behind the lens.
    o.focus_distance_mm = 1.0 / (1.0 / o.focal_mm - 1.0 / lens_to_sensor_mm);
  }
  return o;
}

Result<double> ChannelOptics::image_distance_mm(double object_mm) const {
  return optics::image_distance_mm(focal_mm, object_mm);
}

double ChannelOptics::coc_mm(double object_mm) const {
  auto z_i = image_distance_mm(object_mm);
  if (!z_i) return aperture_mm;
  return aperture_mm * std::fabs(lens_to_sensor_mm - *z_i) / *z_i;
}

}  // namespace camlab::mock
