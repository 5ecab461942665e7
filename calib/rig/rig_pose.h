// Rigid poses as mrcal stores them, rt = (rotation vector r in rad, translation t in m),
// mapping points of one frame into another: x_a = R(r) x_b + t is rt_a_b. The rig solve
// chains them (camera i from board = camera i from camera 0, composed with camera 0 from
// board) and averages the estimates its shared views give.
//
// Reentrant: plain values.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace camlab::calib {

using Rt = std::array<double, 6>;

// R of rt (Rodrigues).
cv::Matx33d rotation_matrix(const Rt& rt);
// rt from R and t.
Rt rt_from(const cv::Matx33d& R, const cv::Vec3d& t);
// rt_a_c = rt_a_b composed with rt_b_c.
Rt compose_rt(const Rt& rt_a_b, const Rt& rt_b_c);
// rt_b_a from rt_a_b.
Rt invert_rt(const Rt& rt_a_b);
// The pose nearest to all of `poses` in the chordal sense: the rotation that is the
// orthogonal projection (SVD) of the mean rotation matrix, and the mean translation.
// Used on estimates of one relative pose from several views; empty input gives identity.
Rt mean_rt(const std::vector<Rt>& poses);
// The angle (deg) of the rotation between two poses' rotations.
double rotation_between_deg(const Rt& a, const Rt& b);

}  // namespace camlab::calib
