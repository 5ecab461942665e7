// A rig pair's images rectified (rectification.h): camera 0's and camera N's images read,
// each checked against its camera's imager size, remapped (bilinear) into the pair's
// rectified geometry, and written as PNG at the input's bit depth (8 or 16 bits, grey or
// colour): a point then lies on one row in both, its disparity along the row.
//
// Reentrant.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/rig/rectification.h"

namespace camlab::calib {

// Writes `out_dir`/rectified-0.png and rectified-N.png (N = r.camera) and returns their
// paths with the rectified geometry: imager, focal length (px), baseline (m), the
// disparity-to-range rule. Errors: "io_error" (an image that does not read, an output that
// does not write), "imager_mismatch" (an image not its camera's size), and
// rectification_maps()'s.
Result<nlohmann::json> rectify_image_files(const StereoRectification& r, const RigSolution& rig,
                                           const std::filesystem::path& image0,
                                           const std::filesystem::path& image_other,
                                           const std::filesystem::path& out_dir);

}  // namespace camlab::calib
