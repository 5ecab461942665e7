#include "calib/rig/board_labels.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

#include "base/format.h"

namespace camlab::calib {

namespace {

// The pose F_q of turned labels: a board point under the old labels is F_q of itself under
// the new ones (a rotation about the board's normal through its centre).
Rt turn_pose(const BoardSpec& b, int q) {
  const double w = (b.cols - 1) * b.spacing_m, h = (b.rows - 1) * b.spacing_m;
  const double angle = q * M_PI / 2;
  const double tx[4] = {0, w, w, 0}, ty[4] = {0, 0, h, h};
  return {0, 0, angle, tx[q & 3], ty[q & 3], 0};
}

// The camera's pose of the board under labels turned q: T o F_q^-1.
Rt turned_pose(const Rt& rt_cam_board, const BoardSpec& b, int q) {
  return q == 0 ? rt_cam_board : compose_rt(rt_cam_board, invert_rt(turn_pose(b, q)));
}

// The consensus of rt_i_j over the views both see, camera i's labels turned per view: the
// candidate (view, turn) that the most other views agree with within 2 deg, and each
// view's turn nearest it. Returns the turns chosen (view -> q).
std::map<int, int> consensus_turns(const ViewPoses& i, const ViewPoses& j, const BoardSpec& b) {
  struct Candidate {
    int view, q;
    Rt rt_i_j;
  };
  std::vector<Candidate> candidates;
  for (const auto& [view, rt_j_board] : j)
    if (auto it = i.find(view); it != i.end())
      for (int q : board_label_turns(b))
        candidates.push_back(
            {view, q, compose_rt(turned_pose(it->second, b, q), invert_rt(rt_j_board))});
  const Candidate* best = nullptr;
  int best_support = -1;
  for (const auto& c : candidates) {  // turn 0 first in each view: it wins ties
    std::map<int, bool> agreeing;
    for (const auto& o : candidates)
      if (rotation_between_deg(c.rt_i_j, o.rt_i_j) < 2) agreeing[o.view] = true;
    const int support = static_cast<int>(agreeing.size());
    if (support > best_support) {
      best = &c;
      best_support = support;
    }
  }
  std::map<int, int> turns;
  if (!best) return turns;
  std::map<int, double> nearest;
  for (const auto& c : candidates) {
    const double d = rotation_between_deg(best->rt_i_j, c.rt_i_j);
    if (!nearest.count(c.view) || d < nearest[c.view]) {
      nearest[c.view] = d;
      turns[c.view] = c.q;
    }
  }
  return turns;
}

}  // namespace

std::vector<int> board_label_turns(const BoardSpec& board) {
  return board.cols == board.rows ? std::vector<int>{0, 1, 2, 3} : std::vector<int>{0, 2};
}

int turned_corner(const BoardSpec& b, int q, int k) {
  const int i = k % b.cols, j = k / b.cols;
  switch (q & 3) {
    case 1:
      return i * b.cols + (b.cols - 1 - j);
    case 2:
      return (b.rows - 1 - j) * b.cols + (b.cols - 1 - i);
    case 3:
      return (b.rows - 1 - i) * b.cols + j;
    default:
      return k;
  }
}

BoardView turned_view(const BoardView& view, const BoardSpec& board, int q) {
  if ((q & 3) == 0) return view;
  BoardView out = view;
  for (size_t k = 0; k < view.corners.size(); ++k)
    out.corners[turned_corner(board, q, static_cast<int>(k))] = view.corners[k];
  return out;
}

Result<RigLabelling> chain_and_label(std::vector<ViewPoses>* poses, const BoardSpec& board,
                                     std::vector<std::string>* warnings) {
  const int n = static_cast<int>(poses->size());
  std::vector<std::vector<int>> shared(n, std::vector<int>(n, 0));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (i != j)
        for (const auto& entry : (*poses)[i]) shared[i][j] += (*poses)[j].count(entry.first) > 0;
  RigLabelling out;
  out.turns.resize(n);
  std::vector<std::optional<Rt>> rt_cam_ref(n);
  rt_cam_ref[0] = Rt{};
  std::vector<int> order{0};
  std::deque<int> queue{0};
  auto turn = [&](int camera, int view, int q) {
    if ((q & 3) == 0) return;
    auto& pose = (*poses)[camera][view];
    pose = turned_pose(pose, board, q);
    const int total = (out.turns[camera][view] + q) & 3;
    if (total == 0)
      out.turns[camera].erase(view);
    else
      out.turns[camera][view] = total;
  };
  while (!queue.empty()) {
    const int j = queue.front();
    queue.pop_front();
    std::vector<int> next;
    for (int i = 0; i < n; ++i)
      if (!rt_cam_ref[i] && shared[i][j] > 0) next.push_back(i);
    std::sort(next.begin(), next.end(), [&](int a, int b) { return shared[a][j] > shared[b][j]; });
    for (int i : next) {
      for (const auto& [view, q] : consensus_turns((*poses)[i], (*poses)[j], board))
        turn(i, view, q);
      std::vector<Rt> estimates;
      for (const auto& [view, rt_i_board] : (*poses)[i])
        if (auto it = (*poses)[j].find(view); it != (*poses)[j].end())
          estimates.push_back(compose_rt(rt_i_board, invert_rt(it->second)));
      rt_cam_ref[i] = compose_rt(mean_rt(estimates), *rt_cam_ref[j]);
      order.push_back(i);
      queue.push_back(i);
    }
  }
  for (int i = 0; i < n; ++i) {
    if (!rt_cam_ref[i])
      return make_error("too_few_views",
                        format_printf("camera %d shares no board view with camera 0, directly "
                                      "or through the other cameras: its pose in the rig is "
                                      "undetermined",
                                      i));
    out.rt_cam_ref.push_back(*rt_cam_ref[i]);
    if (i > 0 && shared[i][0] > 0 && shared[i][0] < 3)
      warnings->push_back(
          format_printf("camera %d shares only %d views with camera 0", i, shared[i][0]));
  }
  // Every view in the labels of the first camera (in chain order) that sees it.
  std::map<int, Rt> board_in_ref;
  for (int c : order)
    for (const auto& [view, rt_c_board] : (*poses)[c]) {
      const Rt here = compose_rt(invert_rt(out.rt_cam_ref[c]), rt_c_board);
      auto first = board_in_ref.find(view);
      if (first == board_in_ref.end()) {
        board_in_ref[view] = here;
        continue;
      }
      int best_q = 0;
      double best_deg = 1e9;
      for (int q : board_label_turns(board)) {
        const double d = rotation_between_deg(
            first->second,
            compose_rt(invert_rt(out.rt_cam_ref[c]), turned_pose(rt_c_board, board, q)));
        if (d < best_deg) {
          best_deg = d;
          best_q = q;
        }
      }
      turn(c, view, best_q);
    }
  for (int c = 0; c < n; ++c)
    if (!out.turns[c].empty())
      warnings->push_back(format_printf(
          "camera %d labelled the board turned against the other cameras in %zu views; "
          "re-labelled (a plain chessboard's corners are named from where the detector "
          "starts)",
          c, out.turns[c].size()));
  return out;
}

}  // namespace camlab::calib
