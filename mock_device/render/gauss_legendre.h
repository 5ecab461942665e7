// Gauss-Legendre nodes and weights on [0, 1], orders 1 to 4: the renderer's cubature rules
// over a pixel's area (pixel_quadrature.h), an aperture cell (aperture_region.h) and the
// pieces of a cell's coverage integral.
//
// Reentrant: constants.
#pragma once

namespace camlab::mock {

struct GaussRule {
  int n;
  double x[4], w[4];
};

constexpr GaussRule kGauss[5] = {
    {0, {}, {}},
    {1, {0.5}, {1.0}},
    {2, {0.21132486540518713, 0.7886751345948129}, {0.5, 0.5}},
    {3, {0.1127016653792583, 0.5, 0.8872983346207417}, {5.0 / 18, 8.0 / 18, 5.0 / 18}},
    {4,
     {0.06943184420297371, 0.33000947820757187, 0.6699905217924281, 0.9305681557970262},
     {0.17392742256872692, 0.32607257743127307, 0.32607257743127307, 0.17392742256872692}},
};

}  // namespace camlab::mock
