// Whether a new view adds a board pose or repeats one already taken. Three views of one
// pose add no geometry, yet each shrinks the solve's covariance as if it did: a guided
// session that took them would report an uncertainty the views do not support. A view is
// a near-duplicate of an earlier one when most of its corners are corners the earlier view
// also shows and those sit where they sat, within near_duplicate_tolerance_px RMS. The
// tolerance is tight on purpose: refusing a pose the user meant to take costs more than
// keeping a near repeat. Two detections of a board that did not move differ by the corner
// noise (0.1-0.5 px); a 5 deg tilt of a board filling half a 1280x800 imager moves its
// corners 3 px, a 5 mm shift at 0.6 m 8 px. A chessboard's labels can come out rotated by
// 180 deg between two detections of one pose, so that correspondence is tried too; a
// ChArUco board's corners carry their ids.
//
// Reentrant.
#pragma once

#include <optional>
#include <string>

#include "calib/calibration_data.h"

namespace camlab::calib {

struct NearDuplicate {
  int view = -1;      // index into the data's views
  double rms_px = 0;  // RMS displacement of the corners both show
  int shared_corners = 0;
  bool rotated_labels = false;  // matched with the chessboard's labels turned 180 deg
};

// The tolerance for `view`: 0.5% of the board's extent in the image (its bounding box's
// diagonal), and at least 1 px, above the noise of two detections.
double near_duplicate_tolerance_px(const BoardView& view);

// The earliest view of `data` that `view` nearly duplicates, if any.
std::optional<NearDuplicate> find_near_duplicate(const CalibrationData& data,
                                                 const BoardView& view);

// "the board sits where it sat in view 3 (frame_000012.png): 96 corners 1.2 px apart RMS;
// move or tilt it (a new pose adds geometry, a repeat does not)".
std::string describe(const NearDuplicate& duplicate, const CalibrationData& data);

}  // namespace camlab::calib
