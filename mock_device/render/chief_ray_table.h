// Chief rays of every pixel corner, from an exact mrcal lens model.
//
// The thin-lens renderer needs, for every sample position on the sensor, the direction of
// the ray through the lens centre. mrcal_unproject is exact but iterative (about 1 us a
// point), so it runs once per camera at the pixel corners; positions inside a pixel are
// interpolated bilinearly between its four corners, which is exact to far below 1e-4 px
// for any lens whose distortion is smooth at the scale of one pixel.
//
// Focus breathing: fx = lens_to_sensor / pitch grows as the lens moves out to focus
// closer. A pixel at q then sees the ray that the reference table has at
// c + (q - c) / ratio, so a table for another focus is a resampling of the reference,
// not another unprojection.
//
// Thread-safe for concurrent reads after construction.
#pragma once

#include <string>
#include <vector>

#include "base/result.h"

namespace camlab::mock {

class ChiefRayTable {
 public:
  // Unprojects the (W+1) x (H+1) pixel corners (pixel centres at integers, so corner
  // (i, j) is at (i - 0.5, j - 0.5)). Corners whose unprojection does not reproject to
  // within 1e-3 px, or that look backwards, are marked invalid.
  static Result<ChiefRayTable> create(const std::string& lensmodel,
                                      const std::vector<double>& intrinsics, int width_px,
                                      int height_px);

  // The table for fx = ratio x this table's fx (ratio >= 1), same principal point: a
  // bilinear resampling, rows split over `threads`.
  ChiefRayTable rescaled(double ratio, int threads = 1) const;

  int width_px() const { return width_; }
  int height_px() const { return height_; }

  // Normalised coordinates (x/z, y/z) of the chief ray at pixel-corner (i, j).
  float xn(int i, int j) const { return xn_[j * (width_ + 1) + i]; }
  float yn(int i, int j) const { return yn_[j * (width_ + 1) + i]; }
  bool valid(int i, int j) const { return valid_[j * (width_ + 1) + i] != 0; }

  // Share of corners that could not be unprojected (outside the model's domain).
  double invalid_fraction() const;

  // The box of the chief rays over all pixel corners of each kBlockPx x kBlockPx block of
  // pixels (block (bx, by) holds pixels [8 bx, 8 bx + 8) x [8 by, 8 by + 8), clipped to
  // the imager), and whether all of them are valid: the renderer classifies blocks by it.
  static constexpr int kBlockPx = 8;
  struct BlockBounds {
    float x_min, x_max, y_min, y_max;
    bool valid;
  };
  const BlockBounds& block_bounds(int bx, int by) const {
    return blocks_[static_cast<size_t>(by) * blocks_x_ + bx];
  }

 private:
  void compute_block_bounds();

  int width_ = 0;
  int height_ = 0;
  double cx_ = 0;
  double cy_ = 0;
  std::vector<float> xn_;
  std::vector<float> yn_;
  std::vector<unsigned char> valid_;
  int blocks_x_ = 0;
  std::vector<BlockBounds> blocks_;
};

}  // namespace camlab::mock
