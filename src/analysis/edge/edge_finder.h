// Automatic slanted-edge finding, for frames whose edge geometry is not known: long,
// straight, high-contrast transitions, found at a scale where even a large blur looks
// sharp, then handed to measure_edge() (edge_measure.h), whose fit refines offset and angle.
//
// Method: the frame is reduced by `scale` (area averaging, so a blur of D px becomes D /
// scale), smoothed, edged with Canny (thresholds from the gradient magnitude's
// percentiles), and Hough segments (OpenCV's probabilistic transform) are merged when
// collinear (angle within 2 degrees, lines within 2 px at the reduced scale) and
// overlapping; parallel lines within 5 reduced px of each other (the ridges a blurred
// edge's flat-topped gradient can leave) count as one. Segments shorter than
// `min_length_px` (full resolution) are dropped. Parallel edges closer than about 5 x
// scale px (a narrow bar) are found as one line: each line whose profile across it, read at
// full resolution, is a bar's (one level both sides, one dip or peak between) is replaced by
// the bar's two edges, at the profile's half-level crossings.
// Edges of every kind are found, target borders included: a border against the
// background is an edge too (measure_edge() rejects what its window cannot hold).
//
// Reentrant.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>

#include "analysis/edge/edge_measure.h"

namespace camlab::analysis {

struct EdgeFinderOptions {
  int scale = 4;              // reduction factor for detection (1 = full resolution)
  double min_length_px = 60;  // shortest segment kept (full-resolution px)
  double min_contrast = 0.0;  // minimum |light - dark| along the segment (image units); 0 = auto
  int max_edges = 64;
};

// Segments named "edge_<n>" in order of decreasing length. Empty when none qualifies.
std::vector<EdgeSegment> find_edges(const cv::Mat& image, const EdgeFinderOptions& options);

}  // namespace camlab::analysis
