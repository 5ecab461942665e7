// camlabd under `camlab vcam run`, with the broker's socket path written to DIR/broker.path
// so that the test (outside the run) can inject faults through the broker as
// `camlab vcam fault` does inside it.
#pragma once

#include <stdlib.h>

#include <string>
#include <vector>

#include "../cli_runner.h"
#include "daemon_harness.h"

namespace camlab::testing {

// The launch prefix: `camlab vcam run --camera C --scene S -- sh -c '...' CAMLABD ARGS...`;
// the shell saves $CAMLAB_VCAM_BROKER and then becomes camlabd.
inline std::vector<std::string> vcam_prefix_saving_broker(const fs::path& dir,
                                                          const std::string& camera,
                                                          const std::string& scene) {
  return {CAMLAB_CLI_PATH,
          "vcam",
          "run",
          "--camera",
          camera,
          "--scene",
          scene,
          "--",
          "/bin/sh",
          "-c",
          "printf %s \"$CAMLAB_VCAM_BROKER\" > '" + (dir / "broker.path").string() +
              "' && exec \"$0\" \"$@\""};
}

// Runs `camlab ARGS` with the saved broker's environment.
inline CliRun run_cli_with_broker(const fs::path& dir, const std::string& args) {
  const std::string broker = read_file(dir / "broker.path");
  if (broker.empty()) return CliRun{-1, "", "no broker.path in " + dir.string()};
  ::setenv("CAMLAB_VCAM_BROKER", broker.c_str(), 1);
  CliRun run = run_cli(args);
  ::unsetenv("CAMLAB_VCAM_BROKER");
  return run;
}

}  // namespace camlab::testing
