// Runs the built `camlab` executable (CAMLAB_CLI_PATH) for end-to-end tests.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace camlab::testing {

struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs `camlab <args>` through the shell; stdout through the pipe, stderr via a file.
inline CliRun run_cli(const std::string& args) {
  char err_path[] = "/tmp/camlab_cli_test_XXXXXX";
  const int fd = mkstemp(err_path);
  if (fd >= 0) close(fd);
  const std::string command = std::string(CAMLAB_CLI_PATH) + " " + args + " 2>" + err_path;
  CliRun run;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[4096];
    for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) run.out.append(buffer, n);
    const int status = pclose(pipe);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::ifstream err_file(err_path);
  std::stringstream err;
  err << err_file.rdbuf();
  run.err = err.str();
  unlink(err_path);
  return run;
}

}  // namespace camlab::testing
