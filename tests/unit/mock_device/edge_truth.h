// The line of a slanted edge as a frame's truth gives it (targets[].edge_px), as the start
// the edge fits of src/analysis/edge take.
#pragma once

#include <cmath>

#include <nlohmann/json.hpp>

#include "analysis/edge/edge_spread.h"

namespace camlab::mock::testing {

inline analysis::EdgeLine edge_line_of_truth(const nlohmann::json& target) {
  const auto& middle = target["edge_px"]["middle"];
  const auto& start = target["edge_px"]["start"];
  const auto& end = target["edge_px"]["end"];
  return {middle[0].get<double>(), middle[1].get<double>(),
          std::atan2(end[1].get<double>() - start[1].get<double>(),
                     end[0].get<double>() - start[0].get<double>())};
}

}  // namespace camlab::mock::testing
