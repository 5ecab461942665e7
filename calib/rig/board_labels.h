// One labelling of the board in every camera of a rig view. A chessboard detector names
// the corners of a plain board from where it starts: two cameras can label one view's
// board 180 deg apart (90 deg for a square grid), and each camera's own solve is none the
// wiser, but a joint solve would see one pose as two. The rig therefore re-labels: the
// relative pose of two cameras is the consensus of their shared views under every turn of
// the labels, each view takes the turn that agrees with it, and once every camera is
// placed each view takes the labelling of the first camera that sees it. (A ChArUco
// board's ids name its corners: its views agree, and stay as they are.)
//
// Reentrant: plain values.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/rig/rig_pose.h"

namespace camlab::calib {

// Per camera: view -> rt_cam_board of its own solve.
using ViewPoses = std::map<int, Rt>;

// The quarter turns under which the board's grid maps onto itself: {0, 2}, or {0, 1, 2, 3}
// for a square grid.
std::vector<int> board_label_turns(const BoardSpec& board);
// Where corner k (row-major) goes when the labels turn q quarter turns.
int turned_corner(const BoardSpec& board, int quarter_turns, int k);
// The board view with its labels turned.
BoardView turned_view(const BoardView& view, const BoardSpec& board, int quarter_turns);

struct RigLabelling {
  std::vector<Rt> rt_cam_ref;             // per camera, camera 0 the identity
  std::vector<std::map<int, int>> turns;  // per camera: view -> quarter turns (0 left out)
};

// Places each camera along the shortest chain of shared views from camera 0 (more shared
// views first among equally short ones), turning labels as above; *poses become the turned
// labels' poses. Error "too_few_views" when a camera is not connected to camera 0.
Result<RigLabelling> chain_and_label(std::vector<ViewPoses>* poses, const BoardSpec& board,
                                     std::vector<std::string>* warnings);

}  // namespace camlab::calib
