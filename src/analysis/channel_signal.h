// A frame's signal for one colour channel, in the form the measurements read.
//
// Blur is measured at full sensor resolution on the sites of one colour: the other sites
// are NaN, which the edge fits skip (edge/edge_fit_core.h), so the fit's model of a
// unit-square pixel stays exact and no demosaicing blur enters the measured CoC. Green
// keeps both of its sites per 2x2 block.
//
// Reentrant: pure functions.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::analysis {

// The channels a frame can be measured in: {""} (one, luminance) for mono frames,
// {"R", "G", "B"} for mosaics and linear RGB frames. JPEG frames: "not_linear".
Result<std::vector<std::string>> measurable_channels(const image::FrameSidecar& sidecar);

// CV_32F of DN above black: the frame's mono samples (channel ""), or those of `channel`
// with every other site NaN (mosaics) / that plane of an RGB frame.
Result<cv::Mat> channel_signal(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                               const std::string& channel);

// The samples of one channel, compact and unchanged (DN, black included), for statistics
// over pixels: the frame itself (mono, channel ""), that plane of an RGB frame, or for a
// mosaic the channel's sample planes side by side (green: its two planes, 2 x (cols/2)
// wide). Pairs of frames give pairs of sample images with the same layout.
Result<cv::Mat> channel_samples(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                                const std::string& channel);

}  // namespace camlab::analysis
