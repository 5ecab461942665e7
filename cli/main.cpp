// camlab: the command-line front end.
#include <cstdio>
#include <exception>
#include <string_view>

#include <CLI/CLI.hpp>

#include "command_errors.h"
#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "camlab: camera optics, a physically based virtual camera, the cameras present, intrinsics\n"
      "calibration with mrcal, measurements of blur, exposure and focus from captures, and\n"
      "light fields (refocusing after capture, depth, lenslet decoding).\n"
      "Every subcommand explains itself with --help; most print JSON with --json. An error is\n"
      "one line on stderr ending in its code (docs/errors.md) and exit status 2; with --json\n"
      "the error is also printed as JSON on stdout."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "camlab 0.1.0");
  camlab::cli::register_optics_command(app);
  camlab::cli::register_render_command(app);
  camlab::cli::register_devices_command(app);
  camlab::cli::register_vcam_command(app);
  camlab::cli::register_calibrate_command(app);
  camlab::cli::register_analyze_command(app);
  camlab::cli::register_lightfield_command(app);
  camlab::cli::register_stereo_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::RuntimeError& e) {
    // A subcommand's failure, reported already (cli/command_errors.h), or the exit status
    // of the command `camlab vcam run` ran.
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    // Options the parser refuses are errors like any other: the same line and code, JSON
    // too when --json was asked for, exit status 2.
    bool json = false;
    for (int i = 1; i < argc; ++i) json = json || std::string_view(argv[i]) == "--json";
    camlab::cli::CommandErrors("camlab", json)
        .report(camlab::make_error("invalid_argument", e.what()));
    std::fprintf(stderr, "Run with --help for more information.\n");
    return 2;
  }
  return 0;
}
