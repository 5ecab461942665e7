// Stereo rectification of a rig's camera pair (camera 0 and camera N): both cameras turned
// to one orientation whose x axis runs along the baseline (from camera 0's centre to camera
// N's), whose z axis is the cameras' mean viewing direction made normal to the baseline,
// and y completes them (z x x); each then sees through one pinhole model. A point is then
// on the same row in both rectified images, so the epipolar residual (the difference of
// the two rows of one board corner) measures what the calibration leaves: 0 for the
// truth, the corner noise for a good calibration, more where the extrinsics are off.
// The construction is mrcal-stereo's (its rectified0/1.cameramodel).
//
// Two rectified models, as mrcal-stereo offers: LENSMODEL_PINHOLE (rows and columns are
// tangents: straight lines stay straight, but the image grows as tan of the half field,
// so past about 120 deg most pixels go to the edges and 180 deg cannot be had), and
// LENSMODEL_LATLON (a transverse equirectangular projection, mrcal_project_latlon: a row
// is the angle of an epipolar plane about the baseline, a column the angle within it, so
// pixels are evenly spread in angle and a fisheye pair's 180 deg fit).
//
// Reentrant.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/rig/rig_solver.h"

namespace camlab::calib {

enum class RectifiedModel { kPinhole, kLatlon };

struct StereoRectification {
  int camera = 1;          // the pair is camera 0 and this one
  Rt rt_rect_ref{};        // rectified frame (at camera 0's centre) from the reference
  Rt rt_rect_other_ref{};  // the other camera's rectified frame: the same turn, at its centre
  double baseline_m = 0;   // distance between the two centres
  double az0_deg = 0;      // the cameras' mean viewing direction off the baseline's normal
  LensModel rectified;     // LENSMODEL_PINHOLE or _LATLON, the same for both rectified cameras
};

// The model that suits a field: lat-lon past 120 deg (az_fov_deg or el_fov_deg, or where
// 0, camera 0's own field), where a pinhole's tangents would spread the pixels badly;
// else the pinhole, whose straight lines stay straight.
RectifiedModel suited_rectified_model(const LensModel& camera0, double az_fov_deg = 0,
                                      double el_fov_deg = 0);

// The pair's rectified geometry; the rectified imager spans az_fov_deg along the baseline
// and el_fov_deg across it (0: camera 0's horizontal and vertical FOV, at most 150 deg for
// a pinhole, 180 for lat-lon) at camera 0's focal length (pixels per radian at the centre,
// for lat-lon). Errors: "out_of_range" (camera, or fields outside (0, 170) deg for a
// pinhole, (0, 180] for lat-lon), "singular" (cameras looking along the baseline, or a
// zero baseline).
Result<StereoRectification> rectify_pair(const RigSolution& rig, int camera, double az_fov_deg = 0,
                                         double el_fov_deg = 0,
                                         RectifiedModel model = RectifiedModel::kPinhole);

// Pixels q (x, y pairs) of camera `which` (0 or the pair's other camera) in the rectified
// image of that camera.
Result<std::vector<double>> rectified_pixels(const StereoRectification& r, const RigSolution& rig,
                                             int which, const std::vector<double>& q_px);

// The epipolar residual of the calibration's own corners: every corner both cameras saw
// in one view, its two rectified rows apart (px).
struct EpipolarResidual {
  double rms_px = 0;
  double worst_px = 0;
  int corners = 0;
  int views = 0;
};
Result<EpipolarResidual> epipolar_residual(const StereoRectification& r, const RigData& data,
                                           const RigSolution& rig);

// The distance (m) from camera 0's centre of a point seen at rectified pixel (x0, y) by
// camera 0 and at column xN by the other camera (the same row). Pinhole: depth z = f B /
// (x0 - xN), then along the ray; lat-lon: the columns are angles in the point's epipolar
// plane, az = (x - cx) / f, and the triangle of the baseline gives B cos(azN) /
// sin(az0 - azN). NaN when the columns do not meet in front (disparity <= 0).
double rectified_range_m(const StereoRectification& r, double x0_px, double y_px, double xN_px);

// cv::remap maps (CV_32FC1, x and y) that make camera `which`'s rectified image from its
// own image.
Result<std::array<cv::Mat, 2>> rectification_maps(const StereoRectification& r,
                                                  const RigSolution& rig, int which);

}  // namespace camlab::calib
