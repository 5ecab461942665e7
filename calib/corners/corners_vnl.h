// mrcal's corners.vnl format, as written by mrgingham and read by mrcal-calibrate-cameras:
//
//   # filename x y level
//   img0.png 123.4 56.7 0
//   img0.png - - -          (a corner that was not found)
//   img1.png - - -          (one row alone: no board in this image)
//
// Each image with a board has cols * rows consecutive rows in mrcal's row-major corner
// order. `level` is the decimation level the corner was found at; its weight is
// 0.5^level. A `weight` column is accepted instead of `level`; with neither, weight 1.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"

namespace camlab::calib {

// Parses corners.vnl text. `board` gives the corner count per image; images listed with
// a single "- - -" row (no board) are skipped. Errors: "bad_vnl" with the line number.
Result<std::vector<BoardView>> parse_corners_vnl(std::string_view text, const BoardSpec& board);
Result<std::vector<BoardView>> read_corners_vnl(const std::filesystem::path& path,
                                                const BoardSpec& board);

// Writes views in the `# filename x y level` form (%.17g: round-trip exact). Weights are
// written as level = -log2(weight).
std::string to_corners_vnl(const std::vector<BoardView>& views);

}  // namespace camlab::calib
