#include "mock_device/render/footprint.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace camlab::mock {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct TargetBounds {
  enum Status { kMiss, kInside, kPartial, kUnknown };
  Status status = kUnknown;
  double u0 = 0, u1 = 0, v0 = 0, v1 = 0;  // every hit's target coordinates lie inside
  double z_min = 0, z_max = kInf;         // and its depth (m)
  double rho = 0;                         // aperture footprint radius, normalised
};

TargetBounds bound_target(const PlaneTarget& t, const FootprintQuery& q) {
  TargetBounds b;
  const double inv_c = 1 / t.c;
  auto inverse_depth = [&](double mx, double my) {
    return (t.n[0] * mx + t.n[1] * my + t.n[2]) * inv_c;
  };
  const double qx[2] = {q.mx0, q.mx1}, qy[2] = {q.my0, q.my1};
  double m_q = 0;
  for (double mx : qx)
    for (double my : qy) {
      const double iz = inverse_depth(mx, my);
      m_q = std::max({m_q, std::fabs(iz - q.q_min), std::fabs(iz - q.q_max)});
    }
  const double r = q.aperture_radius_m;
  const double slope = r * std::sqrt(t.n[0] * t.n[0] + t.n[1] * t.n[1]) * std::fabs(inv_c);
  b.rho = slope < 0.5 ? r * m_q / (1 - slope) : kInf;
  // A plane seen nearly edge-on: its hits cannot be bounded here.
  if (!(b.rho < 0.1)) return b;
  // Every ray meets the plane inside the box grown by rho, at 1/z linear in m: where 1/z
  // <= 0 at all its corners, no ray meets the plane in front of the lens.
  const double ex[2] = {q.mx0 - b.rho, q.mx1 + b.rho}, ey[2] = {q.my0 - b.rho, q.my1 + b.rho};
  double iz_e[4], iz_max = -kInf, iz_min = kInf;
  for (int i = 0; i < 4; ++i) {
    iz_e[i] = inverse_depth(ex[i & 1], ey[i >> 1]);
    iz_max = std::max(iz_max, iz_e[i]);
    iz_min = std::min(iz_min, iz_e[i]);
  }
  if (iz_max <= 0) {
    b.status = TargetBounds::kMiss;
    return b;
  }
  if (!(iz_min > 0)) return b;   // the plane's horizon crosses the footprint
  b.u0 = b.v0 = b.z_min = kInf;  // filled by min/max below
  b.u1 = b.v1 = b.z_max = -kInf;
  for (int i = 0; i < 4; ++i) {
    const double mx = ex[i & 1], my = ey[i >> 1];
    const double z = 1 / iz_e[i];
    const double X[3] = {z * mx, z * my, z};
    const double u = t.au[0] * X[0] + t.au[1] * X[1] + t.au[2] * X[2] - t.au_t;
    const double v = t.av[0] * X[0] + t.av[1] * X[1] + t.av[2] * X[2] - t.av_t;
    b.u0 = std::min(b.u0, u);
    b.u1 = std::max(b.u1, u);
    b.v0 = std::min(b.v0, v);
    b.v1 = std::max(b.v1, v);
    b.z_min = std::min(b.z_min, z);
    b.z_max = std::max(b.z_max, z);
  }
  if (b.u1 < t.x_min || b.u0 > t.x_max || b.v1 < t.y_min || b.v0 > t.y_max)
    b.status = TargetBounds::kMiss;
  else if (b.u0 > t.x_min && b.u1 < t.x_max && b.v0 > t.y_min && b.v1 < t.y_max)
    b.status = TargetBounds::kInside;
  else
    b.status = TargetBounds::kPartial;
  return b;
}

// The edge e_u u + e_v v = e0 of target t's coordinates in the camera frame.
EdgeInCamera edge_in_camera(const PlaneTarget& t, double e_u, double e_v, double e0) {
  EdgeInCamera e{};
  for (int i = 0; i < 3; ++i) {
    e.n[i] = t.n[i];
    e.e[i] = e_u * t.au[i] + e_v * t.av[i];
  }
  e.c = t.c;
  e.k = e_u * t.au_t + e_v * t.av_t + e0;
  return e;
}

LocalStructure structure_over(const PlaneTarget& t, const TargetBounds& b) {
  return t.surface->structure_in(std::max(b.u0, t.x_min), std::min(b.u1, t.x_max),
                                 std::max(b.v0, t.y_min), std::min(b.v1, t.y_max));
}

}  // namespace

std::vector<PlaneTarget> plane_targets(const std::vector<TargetSurface>& surfaces) {
  std::vector<PlaneTarget> out;
  out.reserve(surfaces.size());
  for (const TargetSurface& s : surfaces) {
    PlaneTarget t{};
    const auto n = s.normal(), au = s.u_axis(), av = s.v_axis(), o = s.origin();
    for (int i = 0; i < 3; ++i) {
      t.n[i] = n[static_cast<size_t>(i)];
      t.au[i] = au[static_cast<size_t>(i)];
      t.av[i] = av[static_cast<size_t>(i)];
    }
    t.c = s.plane_offset();
    t.au_t = au[0] * o[0] + au[1] * o[1] + au[2] * o[2];
    t.av_t = av[0] * o[0] + av[1] * o[1] + av[2] * o[2];
    t.x_min = s.x_min();
    t.x_max = s.x_max();
    t.y_min = s.y_min();
    t.y_max = s.y_max();
    t.surface = &s;
    out.push_back(t);
  }
  return out;
}

Footprint classify_footprint(const FootprintQuery& query, const std::vector<PlaneTarget>& targets,
                             const int* candidates, int candidate_count,
                             const RegionValues& background, int* hit, int* hit_count) {
  Footprint out;
  *hit_count = 0;
  // Bounds of the targets that may be hit, kept in `hit` order.
  constexpr int kKept = 8;
  TargetBounds kept[kKept];
  bool unknown = false;
  int cover = -1;  // position in `hit` of the nearest target hit by every ray
  for (int i = 0; i < candidate_count; ++i) {
    const TargetBounds b = bound_target(targets[static_cast<size_t>(candidates[i])], query);
    if (b.status == TargetBounds::kMiss) continue;
    const int k = (*hit_count)++;
    hit[k] = candidates[i];
    out.rho_max = std::max(out.rho_max, b.rho);
    if (b.status == TargetBounds::kUnknown || k >= kKept) {
      unknown = true;
      continue;
    }
    kept[k] = b;
    if (b.status == TargetBounds::kInside && (cover < 0 || b.z_max < kept[cover].z_max)) cover = k;
  }
  if (*hit_count == 0) {
    out.kind = Footprint::kFlat;
    out.flat = background;
    return out;
  }
  if (unknown) return out;
  // The targets that may be in front of the cover somewhere (all of them without one).
  int front = -1, front_count = 0;
  for (int k = 0; k < *hit_count; ++k) {
    if (k == cover) continue;
    if (cover >= 0 && kept[k].z_min > kept[cover].z_max) continue;  // hidden behind it
    front = k;
    ++front_count;
  }
  if (front_count == 0) {
    // One target hit by every ray, nothing in front of it.
    const PlaneTarget& t = targets[static_cast<size_t>(hit[cover])];
    const LocalStructure s = structure_over(t, kept[cover]);
    if (s.kind == LocalStructure::kConstant) {
      out.kind = Footprint::kFlat;
      out.flat = s.negative;
    } else if (s.kind == LocalStructure::kOneLine) {
      out.kind = Footprint::kOneLine;
      out.edge = edge_in_camera(t, s.e_u, s.e_v, s.e0);
      out.negative = s.negative;
      out.positive = s.positive;
    } else if (s.kind == LocalStructure::kSmooth) {
      const TargetBounds& b = kept[cover];
      out.kind = Footprint::kSmooth;
      out.steps = false;
      out.target = hit[cover];
      out.features_across = std::max(b.u1 - b.u0, b.v1 - b.v0) / s.scale_m;
    }
    return out;
  }
  if (front_count > 1) return out;
  // One target in front of a flat one (or the background), partly: its side is the edge.
  const TargetBounds& p = kept[front];
  if (p.status != TargetBounds::kPartial) return out;
  if (cover >= 0 && !(p.z_max < kept[cover].z_min)) return out;
  RegionValues behind = background;
  if (cover >= 0) {
    const LocalStructure s = structure_over(targets[static_cast<size_t>(hit[cover])], kept[cover]);
    if (s.kind != LocalStructure::kConstant) return out;
    behind = s.negative;
  }
  const PlaneTarget& t = targets[static_cast<size_t>(hit[front])];
  const LocalStructure inside = structure_over(t, p);
  if (inside.kind != LocalStructure::kConstant) return out;
  const bool crosses[4] = {p.u0<t.x_min, p.u1> t.x_max, p.v0<t.y_min, p.v1> t.y_max};
  if (crosses[0] + crosses[1] + crosses[2] + crosses[3] != 1) return out;
  // The inside is the positive side.
  double e_u = 0, e_v = 0, e0 = 0;
  if (crosses[0]) e_u = 1, e0 = t.x_min;
  if (crosses[1]) e_u = -1, e0 = -t.x_max;
  if (crosses[2]) e_v = 1, e0 = t.y_min;
  if (crosses[3]) e_v = -1, e0 = -t.y_max;
  if (inside.negative == behind) {
    out.kind = Footprint::kFlat;
    out.flat = behind;
    return out;
  }
  out.kind = Footprint::kOneLine;
  out.edge = edge_in_camera(t, e_u, e_v, e0);
  out.negative = behind;
  out.positive = inside.negative;
  return out;
}

}  // namespace camlab::mock
