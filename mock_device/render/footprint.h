// What a group of sensor points (one pixel, or a block of pixels) can see through the
// lens: the footprint of all their rays on each target, and from it whether they see one
// flat patch (one value, exactly), one straight edge between two flat patches (the
// analytic path of edge_coverage.h), or something the renderer must sample.
//
// The bound: a ray from aperture point o (|o| <= R) towards the point where the chief ray
// c' = (m, 1) meets the plane of focus (1/s = q) meets a plane at depth z at normalised
// position m + o (1/z - q). On a plane n . X = c, 1/z = (n . (m, 1)) / c is linear in m,
// so over a box Q of chief-ray positions every hit lies within
// rho = R max_Q |1/z - q| / (1 - R |n_xy| / |c|) of Q (the plane's slope bounds how far
// 1/z changes over the footprint itself). The box grown by rho maps onto the plane by a
// projective map, so its corners' images bound every hit in target coordinates, and the
// plane's depth over it bounds the hits' depths. A target none of whose bounds meets its
// extent is never hit; one whose bounds lie inside it is hit by every ray; whichever such
// target is nearest hides every target wholly behind it.
//
// Reentrant: reads only its arguments.
#pragma once

#include <vector>

#include "mock_device/render/edge_coverage.h"
#include "mock_device/render/target_surface.h"

namespace camlab::mock {

// One target's plane and extent, flattened for the classifier and the analytic path.
struct PlaneTarget {
  double n[3];  // unit normal (camera frame)
  double c;     // n . origin
  double au[3], av[3];
  double au_t, av_t;  // au . origin, av . origin
  double x_min, x_max, y_min, y_max;
  const TargetSurface* surface;
};

std::vector<PlaneTarget> plane_targets(const std::vector<TargetSurface>& surfaces);

struct FootprintQuery {
  // The box of the group's chief rays (normalised coordinates x/z, y/z).
  double mx0, mx1, my0, my1;
  double aperture_radius_m;
  // The range of q = 1/s (1/m) over the channels the group holds (one for a pixel).
  double q_min, q_max;
};

struct Footprint {
  // kSmooth: one target hit by every ray, nothing in front, its pattern without steps (a
  // texture).
  enum Kind { kFlat, kOneLine, kSmooth, kComplex };
  Kind kind = kComplex;
  // kComplex: whether the footprint may hold steps (edges, corners, several targets); false
  // for a texture too fine for kSmooth.
  bool steps = true;
  RegionValues flat;      // kFlat: every ray sees this (background included)
  EdgeInCamera edge{};    // kOneLine: the edge between the two values
  RegionValues negative;  // kOneLine: E . X < K
  RegionValues positive;  // kOneLine: E . X > K
  int target = -1;        // kSmooth: the target every ray sees
  // kSmooth: the footprint's size on the target in features of its pattern (how much the
  // pattern changes across it).
  double features_across = 0;
  // The largest aperture footprint radius (normalised units) on any target the group may
  // see: the blur the sampled path must resolve. 0 when it sees no target.
  double rho_max = 0;
};

// Classifies the group over the targets `candidates` (indices into `targets`; the others
// are known not to be hit). Writes the targets that may be hit into `hit` (capacity:
// candidates.size()) and their number into *hit_count.
Footprint classify_footprint(const FootprintQuery& query, const std::vector<PlaneTarget>& targets,
                             const int* candidates, int candidate_count,
                             const RegionValues& background, int* hit, int* hit_count);

}  // namespace camlab::mock
