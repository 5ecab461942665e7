// Decoding a raw lenslet image into sub-aperture views (docs/analysis.md, "Light
// fields"): measurement code, from the raw image, the white image and the camera's
// metadata (focal length, f-number, focus, raw pixel pitch) only; never from a renderer's
// truth.
//
// The microlens lattice comes from the white image (microlens_lattice.h). Behind a
// microlens the aperture is imaged mirrored onto a disk one pitch across (the f-numbers
// of the main lens and the microlenses match), so with U = the pitch rounded to whole
// pixels, cell (i, j) of a U x U grid over the aperture lands at
//
//   centre + (pitch / U) (((U-1)/2 - i) e1^ + ((U-1)/2 - j) e1^perp)
//
// (e1^ the lattice's unit row direction). View (i, j)'s pixel (k, l) is the raw image
// there divided by the white image there, times the white of a fully lit pixel (the
// median white at the microlens centres): each raw pixel sees its cell's share of the
// disk, which the white image measures (devignetting). Raw and white are interpolated
// bilinearly at that point, which is a plain pick when the centres fall on pixel centres
// or corners (a sensor aligned with its microlenses), and an approximation otherwise.
// Cells are left out where their raw pixel reaches into a neighbouring microlens's image
// (a disk of half a pitch about its centre, from the fitted lattice: such a pixel adds
// the light of two cells, as between the staggered rows of a hexagonal grid) and where
// their measured lit share is under min_lit_share (behind the rim of the disk the raw
// signal is small, and noise grows as it is divided by the white).
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "analysis/lightfield/light_field.h"
#include "analysis/lightfield/microlens_lattice.h"
#include "base/result.h"
#include "image/lightfield_folder.h"

namespace camlab::analysis::lightfield {

struct DecodeOptions {
  double min_lit_share = 0.5;  // cells lit less than this (0..1) are left out
};

struct DecodedLightField {
  LightField light_field;  // views as signal above black; description with the decoded grid
  MicrolensLattice lattice;
  int views_per_side = 0;
  double full_white_dn = 0;       // the white of a fully lit pixel, above black
  std::vector<double> lit_share;  // measured, per view kept
  int cells_left_out = 0;         // under min_lit_share (or outside the disk)
  std::vector<std::string> warnings;
};

// `raw`, `white`: the lenslet and white images (CV_8U or CV_16U, one size); `optics`:
// the camera's (focal length, f-number, lens-to-sensor distance, focus distance; its
// pixel pitch and principal point are replaced by the decoded lattice's);
// `raw_pixel_pitch_um`: the raw sensor's. Errors: those of find_microlens_lattice;
// "invalid_argument" (images of different sizes or types, min_lit_share not in [0, 1],
// a pitch under 2 px); "no_signal" (no cell lit at min_lit_share).
Result<DecodedLightField> decode_lenslet(const cv::Mat& raw, const cv::Mat& white,
                                         int black_level_dn, const image::LightFieldOptics& optics,
                                         double raw_pixel_pitch_um, const DecodeOptions& options);

// Decodes the lenslet image of light-field folder `dir` into a new light-field folder
// `out_dir` (views as frames at the raw image's bit depth, rounded). Errors: those of
// decode_lenslet and of the folders; "not_found" when `dir` holds no lenslet image.
Result<DecodedLightField> decode_lenslet_folder(const std::filesystem::path& dir,
                                                const std::filesystem::path& out_dir,
                                                const DecodeOptions& options);

}  // namespace camlab::analysis::lightfield
