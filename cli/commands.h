// Registration of the `camlab` subcommands. Each subcommand lives in its own file, parses
// its options with CLI11, calls the libraries and prints (text, or JSON with --json).
// The CLI stays thin: no physics or image processing here.
#pragma once

#include <CLI/CLI.hpp>

namespace camlab::cli {

// `camlab optics fov|dof|coc|exposure|lens|stops` (cli/optics_command.cpp).
void register_optics_command(CLI::App& app);

// `camlab render` (cli/render_command.cpp).
void register_render_command(CLI::App& app);

// `camlab devices` (cli/devices_command.cpp).
void register_devices_command(CLI::App& app);

// `camlab vcam run` (cli/vcam_command.cpp).
void register_vcam_command(CLI::App& app);

// `camlab calibrate` (cli/calibrate_command.cpp).
void register_calibrate_command(CLI::App& app);

// `camlab analyze defocus|exposure|focus|sfr` (cli/analyze_command.cpp).
void register_analyze_command(CLI::App& app);

// `camlab lightfield render|refocus|stack|depth|decode` (cli/lightfield_command.cpp).
void register_lightfield_command(CLI::App& app);

// `camlab stereo rectify|triangulate` (cli/stereo_command.cpp).
void register_stereo_command(CLI::App& app);

}  // namespace camlab::cli
