// A found segment grown along its own line to the whole straight edge. The edge finder
// works at a reduced scale, where a square's side of 80 px is 20 px and its Hough
// segments often cover only part of it (on the lens-map chart, 45-60 px of 80). A slanted
// edge's measurement reads rows whose windows must lie inside the segment (a window
// reaches hw tan(slant) along the edge past its row), so a part-covered side gives half
// the rows, or none: a 45 px piece of a side at 37 deg with a 24 px window has no row that
// fits.
//
// Method, at full resolution: profiles across the segment's line every pixel along it,
// outward past each end, each averaged with its 2 neighbours either side; the edge goes on
// while that average's step has at least half the contrast of the segment's own profiles
// (their median), the same sign, and its centre (the centroid of its derivative within
// 6 px of the line) stays on the line the segment's own profiles fit, within 6 robust
// standard deviations of theirs (at least 0.5 px). The grown end stops 2 px short of
// where it fails (the half-contrast point is where the next side's blur begins). A segment
// is never shortened. Pieces of one side grown into each other are one edge: the shorter
// is dropped.
//
// Reentrant.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>

#include "analysis/edge/edge_measure.h"

namespace camlab::analysis {

struct SegmentExtentOptions {
  double profile_half_width_px = 6;  // across the line; little reach along a slanted edge
  double max_growth = 4.0;           // each end grows by at most this times the length
};

// Whether `e` is a piece of `k`: parallel within 3 deg, its middle within 3 px of k's
// line and within k's extent.
bool piece_of_edge(const EdgeSegment& e, const EdgeSegment& k);

// `image`: single-channel CV_32F. Segments keep their names; a dropped duplicate is gone.
std::vector<EdgeSegment> extend_along_edges(const cv::Mat& image,
                                            const std::vector<EdgeSegment>& segments,
                                            const SegmentExtentOptions& options = {});

}  // namespace camlab::analysis
