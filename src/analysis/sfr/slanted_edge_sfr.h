// ISO 12233 slanted-edge SFR (spatial frequency response) of one edge: how much contrast
// the camera keeps at each spatial frequency across the edge, optics and pixel aperture
// together, and its MTF50, MTF30 and MTF10.
//
// Method (ISO 12233:2014 e-SFR, docs/analysis.md "SFR"):
//   1. the region: pixels within half_length of the segment's middle along it and within
//      half_width across it (cut along the edge, not by whole rows: a row reaches
//      half_width x tan(slant) along the edge past its crossing, over a square's corner);
//      the image is read transposed when the edge is nearer horizontal, so that rows
//      cross it;
//   2. the edge's line: per row whose window lies in the region, the centroid of the
//      row's derivative under a Hamming window; a straight line fitted to the centroids
//      (least squares), twice, the second time with the windows centred on the first line;
//      then the region ends 2 px inside where the edge leaves that line (rows of the whole
//      segment under 6 px windows, three in a row off it: a segment the finder ran past a
//      vertex), and the line is fitted once more;
//   3. the ESF: every pixel of the region binned by its perpendicular distance from the
//      line into bins 1/oversampling px wide (8 a pixel by default: the slant spreads the
//      pixels' phases); each bin's mean value placed at its samples' mean distance, and the ESF
//      on the bin centres interpolated linearly between those (empty bins included);
//      the ESF's tails (past 0.75 rises + 1 px from the edge) smoothed by boxes that widen
//      with the distance, up to 4 px each side: only noise moves the ESF there, and at the
//      frequencies MTF50 lies at (0.1-0.4 cycles/px) that noise was most of the LSF's;
//   4. the LSF: the ESF's central difference, under a window centred on its centroid:
//      flat to 1.25 rises + 1.5 px each side, a cosine taper to twice that (the noise past
//      the spread left out);
//   5. the SFR: the LSF's Fourier transform (evaluated directly, every 0.005 cycles/px),
//      normalised at zero frequency, divided by the central difference's response
//      sin(2 pi f d) / (2 pi f d) (d the bin width) and by the ESF's own smear in step 3,
//      exp(-2 pi^2 f^2 v): v the samples' spread within their bins plus what the
//      interpolation to the bin centres adds, averaged under the LSF.
//   6. the MTF50's standard error: steps 3-5 again on the region less each of 10 blocks
//      of adjacent rows in turn, the spread of those 10 MTF50s (the delete-a-block
//      jackknife): what the edge's own noise, white or not, moves the MTF50 by.
// Frequencies are in cycles per pixel perpendicular to the edge.
//
// Flags (never a silent number): an edge within 2 deg of a pixel axis (too few phases),
// clipped pixels in the region, an ESF window shorter than 3 of the edge's 10-90% rise
// widths, too few rows, a profile that is not one step.
//
// Reentrant: no state.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "analysis/edge/edge_measure.h"
#include "base/result.h"

namespace camlab::analysis {

struct SfrOptions {
  double half_length_px = 0;    // along the edge; 0: the segment's half length less 4 px
  double half_width_px = 24;    // across the edge (each side)
  int oversampling = 8;         // ESF bins per pixel
  double saturation_level = 0;  // image value at which pixels clip; <= 0: not checked
};

inline constexpr std::string_view kSfrOk = "ok";
inline constexpr std::string_view kSfrNearAxis = "near_axis";
// Within a fraction of a degree of 45: the pixel centres fall on a lattice 0.71 px apart
// across the edge, too coarse for the ESF, unless the rows drift across it.
inline constexpr std::string_view kSfrNearDiagonal = "near_diagonal";
inline constexpr std::string_view kSfrClipped = "clipped";
inline constexpr std::string_view kSfrWindowTooShort = "window_too_short";
inline constexpr std::string_view kSfrTooFewRows = "too_few_rows";
inline constexpr std::string_view kSfrNoEdge = "no_edge";  // no step across the region
// The profile is not one step (a bar, a line, a group of bars or texture): its line
// spread dips below zero by over a third of its rise, or its SFR never falls to 0.5
// (which an area-sampling pixel alone makes it do by 0.6 cycles/px).
inline constexpr std::string_view kSfrNotAStep = "not_a_step";
// Another edge runs through the region (neighbour_in_region()): its step would sit in the
// ESF beside this one's.
inline constexpr std::string_view kSfrNeighbourInRegion = "neighbour_in_region";

struct SfrResult {
  std::string status = std::string(kSfrOk);  // kSfr...; anything but ok: figures not to be used
  std::string message;                       // why, when not ok
  double angle_deg = 0;  // the edge's direction in the image, (-90, 90], 0 = along +x
  double slant_deg = 0;  // off the nearest pixel axis, 0..45
  double centre_x_px = 0, centre_y_px = 0;
  // Where the edge lies across the line it was measured on: the windowed line spread's
  // centroid, as a vector along the line's normal (image px). ~0 on its own line; for one
  // colour measured on the luminance's line, how far that colour's edge sits from it
  // (lateral colour).
  double offset_x_px = 0, offset_y_px = 0;
  double rise_10_90_px = 0;                                     // the ESF's 10-90% rise distance
  double contrast = 0;                                          // light - dark level of the ESF
  std::vector<double> frequency_cy_px, sfr;                     // the curve, 0 to 1 cycle/px
  std::optional<double> mtf50_cy_px, mtf30_cy_px, mtf10_cy_px;  // none: not reached below 1
  // The MTF50's 1-sigma standard error from the region's own scatter: a jackknife over 10
  // blocks of adjacent rows. None where the MTF50 is, or a block holds no pixels.
  std::optional<double> mtf50_standard_error_cy_px;
};

// The SFR of `edge` in a single-channel image (any depth; read as float). Errors:
// "bad_image" (empty or multi-channel), "invalid_argument" (options out of range, a
// segment shorter than 8 px). A region the edge cannot be measured in is a result with a
// status, not an error.
Result<SfrResult> slanted_edge_sfr(const cv::Mat& image, const EdgeSegment& edge,
                                   const SfrOptions& options = {});

// The same with the edge's line found on `geometry` and the ESF read from `signal` (the
// same size): one colour of a raw mosaic, its other sites NaN (channel_signal.h), measured
// on the line its luminance shows. NaN samples are skipped.
Result<SfrResult> slanted_edge_sfr(const cv::Mat& signal, const cv::Mat& geometry,
                                   const EdgeSegment& edge, const SfrOptions& options = {});

// Another edge of `edges` (not `edges[self]`, nor a collinear piece of the same edge)
// that passes through the SFR region of `edges[self]` under `options`: within the half
// width of its line, inside its length by more than 6 px (an adjacent side of a square
// meets it at the region's end; the finder places ends within a few px). The neighbour's
// index and its least distance from the line (px); none when the region is clear.
struct NeighbourInRegion {
  size_t index = 0;
  double distance_px = 0;
};
std::optional<NeighbourInRegion> neighbour_in_region(const std::vector<EdgeSegment>& edges,
                                                     size_t self, const SfrOptions& options = {});

// The frequency (cycles/px) where `sfr` first falls to `level`, linearly interpolated;
// none when it stays above.
std::optional<double> frequency_at(const std::vector<double>& frequency_cy_px,
                                   const std::vector<double>& sfr, double level);

}  // namespace camlab::analysis
