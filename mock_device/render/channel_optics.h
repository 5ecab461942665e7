// The thin lens as one colour channel sees it. Longitudinal chromatic aberration gives
// each channel c its own focal length f_c = f + shift_c (lens.chromatic_focus_shift_mm)
// while the aperture stays the nominal one, A = f / N, and the chief ray through the lens
// centre is the same for every channel (so is the image scale). Channel c then:
//
//   images an object at z_o at      z_i,c = 1 / (1/f_c - 1/z_o)
//   is sharp for objects at         s_c = 1 / (1/f_c - 1/z_s)   (z_s: lens to sensor)
//   blurs a point at z_o into       C_c = A |z_s - z_i,c| / z_i,c
//
// which is the blur the renderer's rays give when each channel aims them at its own
// plane of focus s_c (docs/physics.md). When f_c > z_s, s_c is negative: the channel
// focuses "beyond infinity", and even a point at infinity is blurred.
//
// The grey channel of a monochrome sensor is the nominal lens (shift 0), computed with
// src/optics as it always was.
//
// Reentrant: plain values.
#pragma once

#include "base/result.h"
#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

struct ChannelOptics {
  int channel = 3;  // kRed .. kGrey (target_surface.h)
  double focal_mm = 0;
  double aperture_mm = 0;        // f / N of the nominal focal length
  double lens_to_sensor_mm = 0;  // z_s
  // s_c in mm: +infinity when the channel focuses at infinity, negative beyond it.
  double focus_distance_mm = 0;

  // The channel's image distance of an object at `object_mm` (may be infinite); an error
  // when the object is at or inside f_c (no real image).
  Result<double> image_distance_mm(double object_mm) const;

  // Blur-disk diameter (mm on the sensor) of a point at `object_mm`. A point at or
  // inside f_c has no real image: the aperture-sized blur it would give at f_c, never NaN.
  double coc_mm(double object_mm) const;
};

// Channel c's image scale about the principal point (lateral colour,
// lens.lateral_colour_px): 1 + shift / half diagonal (px); 1 for kGrey.
double channel_image_scale(const CameraSpec& camera, int channel);

// `channel` kRed, kGreen, kBlue or kGrey; lens_to_sensor_mm >= the nominal focal length.
Result<ChannelOptics> channel_optics(const CameraSpec& camera, int channel, double f_number,
                                     double lens_to_sensor_mm);

}  // namespace camlab::mock
