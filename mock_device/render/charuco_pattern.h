// The pattern of a ChArUco target in its own coordinates: a chessboard whose light squares
// hold ArUco markers, laid out as OpenCV 4.6's cv::aruco::CharucoBoard::create lays a
// board out (tests/unit/mock_device/charuco_render_test.cpp compares it with
// CharucoBoard::draw): square (a, b) (a = 0 .. cols - 1 across, b = 0 .. rows - 1 down) is
// dark when a + b is even, so the top-left square is dark; the light squares hold the
// markers 0, 1, 2, ... in row-major order, each centred in its square, each a grid of
// (bits + 2) x (bits + 2) equal cells whose outer ring is black (image/aruco_dictionary.h).
//
// Target coordinates are the scene spec's (mock_device/spec/scene_spec.h): the origin is
// the first inner corner, so square (a, b) covers u in [(a - 1) s, a s], v in
// [(b - 1) s, b s] for square side s, and inner corner (i, j), ChArUco id
// j * (cols - 1) + i, is at (i s, j s).
//
// The pattern is piecewise constant over axis-parallel rectangles, so the renderer's
// exact paths apply to it as to a chessboard: a box of the target that holds one value is
// flat, one that holds one straight step is an edge (structure_in).
//
// Thread-safe for concurrent reads after construction (immutable).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "base/result.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

class CharucoPattern {
 public:
  // The pattern of a ChArUco target spec (type kCharuco). Errors are the dictionary
  // lookup's (image/aruco_dictionary.h); parse_scene_spec has already ruled them out for a
  // parsed spec.
  static Result<std::shared_ptr<const CharucoPattern>> create(const TargetSpec& spec);

  // Whether target point (u, v) (m) is light: the quiet zone around the squares, a light
  // square outside its marker, a white cell of a marker.
  bool light_at(double u, double v) const;

  // What the pattern holds over the box [u0, u1] x [v0, v1] (m): one value (kConstant,
  // `negative_light`), two values split by one axis-parallel line e_u u + e_v v = e0
  // (kOneLine: `negative_light` where e_u u + e_v v < e0, `positive_light` beyond), or more
  // (kComplex). Exact: every step of the pattern inside the box is considered, and a grid
  // line between cells of the same value is no step.
  struct Structure {
    enum Kind { kConstant, kOneLine, kComplex };
    Kind kind = kComplex;
    bool negative_light = false;
    bool positive_light = false;
    double e_u = 0, e_v = 0, e0 = 0;
  };
  Structure structure_in(double u0, double u1, double v0, double v1) const;

  // The marker in square (a, b), or -1 for a dark square or one off the board.
  int marker_in_square(int a, int b) const;

 private:
  CharucoPattern() = default;
  // The steps of the pattern along one axis strictly inside (lo, hi): square sides and
  // marker cell sides of the squares the interval meets, sorted. False when there are more
  // than `max_steps` (the box is then complex).
  bool steps_in(double lo, double hi, int squares, std::vector<double>* steps) const;

  int squares_cols_ = 0, squares_rows_ = 0;
  double square_m_ = 0;
  double inset_m_ = 0;  // from a square's side to its marker's: (square - marker) / 2
  double cell_m_ = 0;   // a marker cell's side: marker / cells
  int cells_ = 0;       // marker cells per side, the black border included
  std::vector<int> marker_of_square_;                  // b * cols + a -> marker id, or -1
  std::vector<std::vector<uint8_t>> cells_by_marker_;  // cells_ x cells_, 1 = white
};

}  // namespace camlab::mock
