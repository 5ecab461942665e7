// The settings the virtual camera's commands render with (`camlab render`, `camlab
// lightfield render`): the camera spec's control defaults, then each `--set name=value`
// (names as mock::apply_setting takes them). A bad --set ends the command.
#pragma once

#include <string>
#include <vector>

#include "command_errors.h"
#include "mock_device/render/renderer.h"

namespace camlab::cli {

mock::RenderSettings settings_from_sets(const CommandErrors& errors, const mock::Renderer& renderer,
                                        const std::vector<std::string>& sets);

}  // namespace camlab::cli
