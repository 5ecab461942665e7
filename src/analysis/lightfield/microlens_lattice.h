// The microlens lattice of a plenoptic camera, found from its white (flat-field) image
// alone, as real plenoptic pipelines find it: the centres of the microlens images, then a
// lattice fitted to them (docs/analysis.md, "Light fields").
//
// 1. The lattice's spacing: the lowest-frequency strong peak (a local maximum above a
//    quarter of the strongest) of the white image's spectrum (a Hann-windowed crop) away
//    from zero frequency: 1/|g| is the spacing of its rows of microlens images.
// 2. Candidate centres: local maxima of the white image smoothed at a quarter of that
//    spacing, above half the brightest, at least 1.25 spacings from the border (nearer,
//    the smoothing sees the border's reflection); at most 600 of them, spread over the
//    image.
// 3. Each centre refined to the point about which the white is most nearly centrally
//    symmetric over half a spacing around it (the sum of squared differences of mirrored
//    samples, bilinear, by grid searches down to 0.004 px): a microlens image is
//    centrally symmetric about its centre whether its top is flat (a plain centroid, or
//    the peak of a flat top, says little of where that is) or not.
// 4. The lattice: the nearest neighbour along +x gives the pitch vector e1; a neighbour
//    below either along e1's normal (a square grid) or half a pitch aside (a hexagonal
//    grid, rows staggered), e2. Every centre gets integer indices in that basis, and
//    origin, e1 and e2 are fitted by least squares to all of them.
//
// Reentrant.
#pragma once

#include <array>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::analysis::lightfield {

// Microlens (k, l), row l, column k: centre = origin + k e1 + floor(l/2) pair + (l odd ?
// e2 : 0), pair the step over two rows: e2 = pair / 2 for a square lattice, e2 half a
// pitch aside of it for a staggered (hexagonal) one. Pixel centres at integer coordinates.
struct MicrolensLattice {
  std::array<double, 2> origin_px{0, 0};  // centre of microlens (0, 0): top-left whole image
  std::array<double, 2> e1_px{0, 0};      // to the next microlens in the row
  std::array<double, 2> e2_px{0, 0};      // from row 0's microlens k to row 1's microlens k
  std::array<double, 2> pair_px{0, 0};    // from row l's microlens k to row l + 2's
  bool staggered = false;
  // Rows apart (along e1's normal) and odd rows' shift along e1, in pitches: the views'
  // lattice (image/lightfield_folder.h, ViewLattice).
  double row_pitch() const;
  double odd_row_shift() const;
  int columns = 0, rows = 0;  // microlenses whose image lies inside the raw image
  int centres_found = 0;      // centres the fit used
  double fit_rms_px = 0;      // of the centres about the fitted lattice
  double pitch_px() const;    // |e1|
  std::array<double, 2> centre(int k, int l) const;
};

// The lattice as JSON: layout ("square" or "hex"), pitch_px, origin_px, e1_px, e2_px,
// pair_px, columns, rows, centres_found, fit_rms_px.
nlohmann::json to_json(const MicrolensLattice& lattice);

// Errors: "no_signal" (a white image without light above black), "no_contrast" (no
// lattice in it), "too_few_samples" (fewer than 4 microlens images found).
Result<MicrolensLattice> find_microlens_lattice(const cv::Mat& white, int black_level_dn);

}  // namespace camlab::analysis::lightfield
