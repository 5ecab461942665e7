// A fresh, empty directory under the temp dir for an analysis test (no renderer needed:
// capture_fixture.h includes this for the tests that render).
#pragma once

#include <filesystem>
#include <string>

#include <unistd.h>

namespace camlab::analysis::testing {

inline std::filesystem::path fresh_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("camlab_analysis_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

}  // namespace camlab::analysis::testing
