// TargetSurface::structure_in: a target's pattern over a box of its coordinates, for the
// renderer's flat and straight-edge paths. Each case follows reflectance_at (target_surface.cpp)
// exactly: the same cells, bars and sides, so a box called constant here is one value
// there.
#include <algorithm>
#include <cmath>

#include "mock_device/render/target_surface.h"

namespace camlab::mock {

namespace {

LocalStructure constant(const RegionValues& v) {
  LocalStructure s;
  s.kind = LocalStructure::kConstant;
  s.negative = v;
  return s;
}

// Two values split by e_u u + e_v v = e0; the same value on both sides is one value.
LocalStructure split(const RegionValues& negative, const RegionValues& positive, double e_u,
                     double e_v, double e0) {
  if (negative == positive) return constant(negative);
  LocalStructure s;
  s.kind = LocalStructure::kOneLine;
  s.negative = negative;
  s.positive = positive;
  s.e_u = e_u;
  s.e_v = e_v;
  s.e0 = e0;
  return s;
}

LocalStructure complex_structure() { return LocalStructure{}; }

}  // namespace

RegionValues TargetSurface::dark_values() const {
  RegionValues v;
  for (int c = 0; c <= kGrey; ++c) v.by_channel[c] = grey_ ? dark_[kGrey] : dark_[c];
  return v;
}

RegionValues TargetSurface::light_values() const {
  RegionValues v;
  for (int c = 0; c <= kGrey; ++c) v.by_channel[c] = grey_ ? light_[kGrey] : light_[c];
  return v;
}

LocalStructure TargetSurface::structure_in(double u0, double u1, double v0, double v1) const {
  const TargetSpec& s = *spec_;
  switch (s.type) {
    case TargetType::kUniform:
      return constant(light_values());
    case TargetType::kTexture: {
      LocalStructure smooth;
      smooth.kind = LocalStructure::kSmooth;
      smooth.scale_m = s.feature_m;
      return smooth;
    }
    case TargetType::kSlantedEdge: {
      // Light where u cos a - v sin a >= 0; a linear function's extremes over a box are at
      // its corners.
      const double f[4] = {u0 * edge_cos_ - v0 * edge_sin_, u1 * edge_cos_ - v0 * edge_sin_,
                           u0 * edge_cos_ - v1 * edge_sin_, u1 * edge_cos_ - v1 * edge_sin_};
      const double lo = std::min({f[0], f[1], f[2], f[3]});
      const double hi = std::max({f[0], f[1], f[2], f[3]});
      if (lo >= 0) return constant(light_values());
      if (hi < 0) return constant(dark_values());
      return split(dark_values(), light_values(), edge_cos_, -edge_sin_, 0.0);
    }
    case TargetType::kChessboard: {
      // Cell (i, j) = (floor(u / square), floor(v / square)); the board's cells are
      // i in [-1, cols - 1], j in [-1, rows - 1]; outside them the quiet zone is light.
      const double sq = s.square_m;
      const double i0 = std::floor(u0 / sq), i1 = std::floor(u1 / sq);
      const double j0 = std::floor(v0 / sq), j1 = std::floor(v1 / sq);
      auto cell = [&](double i, double j) {
        if (i < -1 || j < -1 || i > s.corners_cols - 1 || j > s.corners_rows - 1)
          return light_values();
        return (static_cast<long>(i + j) & 1) == 0 ? dark_values() : light_values();
      };
      if (s.markers) {
        // A box that reaches a marker disc's bounding square is no straight-edge case.
        const auto [a, b] = s.marker_square();
        const double r = TargetSpec::kMarkerRadiusSquares * sq;
        for (const auto& [sa, sb] :
             {std::array{a, b}, std::array{a, b - 1}, std::array{a + 1, b}}) {
          const double cu = (sa - 0.5) * sq, cv = (sb - 0.5) * sq;
          if (u1 >= cu - r && u0 <= cu + r && v1 >= cv - r && v0 <= cv + r)
            return complex_structure();
        }
      }
      if (i1 - i0 > 1 || j1 - j0 > 1) {
        // Several cells: one value only if the box lies in the quiet zone.
        const bool outside =
            i1 < -1 || i0 > s.corners_cols - 1 || j1 < -1 || j0 > s.corners_rows - 1;
        return outside ? constant(light_values()) : complex_structure();
      }
      const RegionValues a = cell(i0, j0), b = cell(i1, j0), c = cell(i0, j1), d = cell(i1, j1);
      if (a == b && a == c && a == d) return constant(a);
      if (a == c && b == d) return split(a, b, 1, 0, i1 * sq);  // split at u = i1 sq
      if (a == b && c == d) return split(a, c, 0, 1, j1 * sq);  // split at v = j1 sq
      return complex_structure();
    }
    case TargetType::kCharuco: {
      const CharucoPattern::Structure c = charuco_->structure_in(u0, u1, v0, v1);
      const RegionValues neg = c.negative_light ? light_values() : dark_values();
      const RegionValues pos = c.positive_light ? light_values() : dark_values();
      if (c.kind == CharucoPattern::Structure::kConstant) return constant(neg);
      if (c.kind == CharucoPattern::Structure::kOneLine) return split(neg, pos, c.e_u, c.e_v, c.e0);
      return complex_structure();
    }
    case TargetType::kBars: {
      // Along u only: x = u + total / 2; bar k covers [k period, k period + width); the
      // breakpoints are 0, width, period, period + width, ..., total.
      const double period = s.bar_width_m + s.bar_gap_m;
      const double total = s.bar_count * period - s.bar_gap_m;
      const double x0 = u0 + total / 2, x1 = u1 + total / 2;
      auto value_at = [&](double x) {
        if (x < 0 || x >= total) return light_values();
        return std::fmod(x, period) < s.bar_width_m ? dark_values() : light_values();
      };
      // Breakpoints strictly inside (x0, x1]: at most one for a line, none for a value.
      int found = 0;
      double at = 0;
      const double k_lo = std::max(0.0, std::floor(x0 / period) - 1);
      const double k_hi = std::min<double>(s.bar_count - 1, std::floor(x1 / period) + 1);
      for (double k = k_lo; k <= k_hi && found < 2; ++k) {
        for (double b : {k * period, k * period + s.bar_width_m}) {
          if (b > x0 && b <= x1) {
            ++found;
            at = b;
          }
        }
      }
      if (found == 0) return constant(value_at(0.5 * (x0 + x1)));
      if (found >= 2) return complex_structure();
      return split(value_at(at - 0.5 * (at - x0)), value_at(at + 0.5 * (x1 - at)), 1, 0,
                   at - total / 2);
    }
  }
  return complex_structure();
}

}  // namespace camlab::mock
