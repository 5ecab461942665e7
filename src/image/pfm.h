// PFM, the portable float map of the stereo benchmarks (Middlebury): how camlab stores a
// float image such as a depth map (metres) beside a capture. A grey PFM is the text
// "Pf\n<width> <height>\n-1.0\n" (a negative scale: little-endian) and the rows of 32-bit
// floats from the bottom row up. Written and read on little-endian hosts.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::image {

// The bytes of a CV_32F single-channel image as a grey PFM.
std::string encode_pfm(const cv::Mat& image);

// A grey PFM's image (CV_32F). Errors: "bad_image" naming `what` (the file) when the
// bytes are not a little-endian grey PFM of the size its header says.
Result<cv::Mat> decode_pfm(const std::string& bytes, const std::string& what);

// encode_pfm into a file, atomically; read_pfm reads one back. Errors: "io_error",
// "bad_image".
Status write_pfm(const std::filesystem::path& path, const cv::Mat& image);
Result<cv::Mat> read_pfm(const std::filesystem::path& path);

}  // namespace camlab::image
