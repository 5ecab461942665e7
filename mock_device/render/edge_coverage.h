// Exact coverage of a straight edge seen through a thin lens: the renderer's analytic path.
//
// A sensor point x' sees, through the aperture disk (radius R), every ray from an aperture
// point o towards the point x''' where its chief ray meets the plane of focus. Rays through
// one point (x''') map the aperture plane onto a target's plane by a central projection,
// which maps straight lines to straight lines: the target's points on one side of a
// straight edge are seen through the aperture points on one side of a line. So the share
// of the aperture that sees the edge's positive side is the area of a circular segment,
// C(h), with h the signed distance of the disk's centre from that line in units of R
// (positive on the positive side). With the target plane n . X = c, the edge
// E . X = K (E, K: the edge's line in the target frame, carried into the camera frame)
// and q = 1 / s (s the plane of focus; 0 at infinity, negative beyond it), the line in
// aperture coordinates o is w . o + w0 = 0 with, for the chief ray c' = (xn, yn, 1):
//
//   w  = (n . c' - c q) E_xy + (K q - E . c') n_xy
//   w0 = c (E . c') - K (n . c')
//   h  = sign(c) w0 / (|w| R)
//
// (the derivation is in docs/virtual-camera.md, "Straight edges through a thin lens").
// Over a pixel the renderer's chief rays are bilinear in the pixel's corners, so h is
// close to linear there; the mean of C over the pixel is then a closed form in C's second
// antiderivative (pixel_mean_coverage). In focus (R |1/z - q| -> 0) h grows without bound
// and the same formula becomes the exact share of the pixel's area on each side.
//
// Reentrant: pure functions.
#pragma once

namespace camlab::mock {

// Share of the unit disk on the side of a line (at signed distance h from the centre)
// that holds the centre when h > 0: 0 for h <= -1, 1 for h >= 1.
double disk_coverage(double h);
// Its antiderivatives from -infinity: C1 (= h for h >= 1) and C2 (= h^2 / 2 + 1/8 for
// h >= 1).
double disk_coverage_integral(double h);
double disk_coverage_second_integral(double h);

// A straight edge on a target plane, in the camera frame (metres): the plane n . X = c,
// the edge's positive side E . X > K.
struct EdgeInCamera {
  double n[3];
  double c;
  double e[3];
  double k;
};

// h (above) for the chief ray (xn, yn, 1), the aperture radius R (m) and q = 1/s (1/m).
// `w_norm` receives |w| R (how fast h changes: 0 exactly in focus). An exactly focused
// point (|w| = 0) is on one side entirely: h = +-1e300, or 0 on the edge itself.
double aperture_edge_distance(const EdgeInCamera& edge, double xn, double yn,
                              double aperture_radius_m, double inverse_focus_m,
                              double* w_norm = nullptr);

// The mean of disk_coverage over a pixel on which h is linear: h_centre at its centre,
// changing by slope_a across it in one direction and by slope_b in the other.
double pixel_mean_coverage(double h_centre, double slope_a, double slope_b);

// The same limit in focus: the share of the pixel where a linear function (value at the
// centre, changes across the pixel) is positive.
double pixel_positive_share(double centre, double slope_a, double slope_b);

// The mean coverage of the edge's positive side over one pixel, from its four corners
// (00, 10, 01, 11: x then y), each given as sign(c) w0 and |w| R (aperture_edge_terms).
// h is taken as linear over the pixel; when the corners say that costs more than
// `tolerance` (in coverage, 0..1) the result is NaN, and the caller integrates the pixel
// with samples instead.
struct EdgeTerms {
  double signed_w0 = 0;  // sign(c) w0
  double w_norm = 0;     // |w| R
  // sign(c) w / |w|: the aperture line's unit normal towards the positive side (0, 0 in
  // focus). The whole disk needs only h; a part of it (a light field's sub-aperture,
  // aperture_region.h) needs the line's direction too.
  double dir_x = 0, dir_y = 0;
};
EdgeTerms aperture_edge_terms(const EdgeInCamera& edge, double xn, double yn,
                              double aperture_radius_m, double inverse_focus_m);
double pixel_edge_coverage(const EdgeTerms corners[4], double tolerance);

// h over one pixel from its corners' terms, linearised: what pixel_edge_coverage
// integrates over the disk, and a light field's sub-apertures over their own regions.
struct PixelH {
  enum Side {
    kNegative,  // every point of the pixel and of the aperture on the negative side
    kPositive,  // ... on the positive side
    kInFocus,   // |w| = 0: centre, slopes are sign(c) w0's (the edge's own line)
    kLinear,    // centre, slopes are h's
  };
  Side side = kNegative;
  double centre = 0, slope_a = 0, slope_b = 0;
  // kLinear: a bound on how far the linear h is from the exact one where |h| <= 1 (the
  // bilinear twist and the change of |w| over the pixel); kInFocus: the twist relative
  // to the gradient.
  double error_h = 0;
  // kLinear: the mean unit normal of the aperture line, and how far the corners' normals
  // stray from it (a shift of dir . p, |p| <= 1).
  double dir_x = 0, dir_y = 0, dir_error = 0;
};
PixelH pixel_h(const EdgeTerms corners[4]);

}  // namespace camlab::mock
