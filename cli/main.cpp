// camlab: the command-line front end.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "camlab: camera optics, virtual-camera rendering and (to come) calibration and "
      "analysis.\nEvery subcommand explains itself with --help; most print JSON with --json."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "camlab 0.1.0");
  camlab::cli::register_optics_command(app);
  camlab::cli::register_render_command(app);
  camlab::cli::register_devices_command(app);
  camlab::cli::register_vcam_command(app);
  camlab::cli::register_calibrate_command(app);
  camlab::cli::register_analyze_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  // Subcommands run from their callbacks and report failure by throwing CLI::RuntimeError
  // with the exit code, after printing a specific message to stderr.
  return 0;
}
