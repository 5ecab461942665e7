// Sub-pixel resampling of light-field views: the one interpolation refocusing and depth
// estimation make (docs/physics.md, "Light fields").
//
// A view is an image on its lattice (image/lightfield_folder.h, ViewLattice): row l at
// y = l row_pitch, its pixel k at x = k + (l odd ? odd_row_shift : 0), in view pixels.
// Output pixel (i, j) of a square grid samples the view at x = scale i + offset_x,
// y = scale j + offset_y: refocusing's shift and magnification are that affine map, the
// same for every row and column, so the interpolation is separable: each lattice row is
// interpolated at the output columns' x (its own shift), then the rows at the output
// rows' y. The kernel is Lanczos-3 (6 taps, normalised), with the fractional positions
// exact (no table, unlike OpenCV's remap, which rounds them to 1/32 px). Samples outside
// the view take its nearest edge pixel.
//
// No interpolation is exact for an edge sharper than a pixel: averaged over views whose
// fractional shifts spread over a pixel, a pixel-integrated step comes out blurred by
// the kernel. Refocused at its own distance, a perfect lens's edge reads up to 11.6% of
// its contrast off at its pixels (2.4% RMS over 17 px), one blurred by the lens's own
// sigma of 0.8 px 2.3% (0.58% RMS) (9 x 9 views; docs/BENCHMARKS.md, "Light fields").
//
// Thread-compatible: one resampler per thread (it keeps scratch between views).
#pragma once

#include <opencv2/core.hpp>

#include "image/lightfield_folder.h"

namespace camlab::analysis::lightfield {

class LatticeResampler {
 public:
  // Views of `view_size` (columns x lattice rows) on `lattice`, resampled onto an output
  // grid of `out_size`.
  LatticeResampler(const image::ViewLattice& lattice, cv::Size view_size, cv::Size out_size);

  // The output grid that covers a view's lattice with square pixels of one view pixel.
  static cv::Size square_grid_size(const image::ViewLattice& lattice, cv::Size view_size);

  // out(j, i) += weight x view(scale i + offset_x, scale j + offset_y). `view` CV_32F of
  // view_size; `out` CV_32F of out_size.
  void accumulate(const cv::Mat& view, double scale, double offset_x, double offset_y, float weight,
                  cv::Mat& out);

  // The same into a fresh image (weight 1).
  cv::Mat resample(const cv::Mat& view, double scale, double offset_x, double offset_y);

 private:
  image::ViewLattice lattice_;
  cv::Size view_size_, out_size_;
  cv::Mat rows_;  // scratch: each lattice row interpolated at the output columns
};

}  // namespace camlab::analysis::lightfield
