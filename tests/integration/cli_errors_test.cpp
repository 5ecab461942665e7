// One error path for every `camlab` subcommand (cli/command_errors.h, docs/errors.md): a
// failure is exit status 2 and one line on stderr ending in its code, and with --json the
// same error as {"error": {"code", "message"}} on stdout, whatever failed: the parser, a
// spec file, a capture folder or the optics.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "base/error_code.h"
#include "cli_runner.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

struct Case {
  const char* args;           // after `camlab`, without --json
  const char* expected_code;  // the error's code
};

void PrintTo(const Case& c, std::ostream* out) { *out << "camlab " << c.args; }

class CliErrors : public ::testing::TestWithParam<Case> {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("camlab_cli_errors_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "not_a_capture");
    std::ofstream(dir_ / "broken.json") << "{\"sensor\": ";
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string in_dir(std::string args) {
    for (size_t at; (at = args.find("DIR")) != std::string::npos;)
      args.replace(at, 3, dir_.string());
    return args;
  }
  static fs::path dir_;
};
fs::path CliErrors::dir_;

TEST_P(CliErrors, JsonErrorOnStdoutCodedLineOnStderrExitTwo) {
  const Case& c = GetParam();
  const auto run = run_cli(in_dir(c.args) + " --json");
  EXPECT_EQ(run.exit_code, 2) << c.args << "\n" << run.err;
  // stderr: "camlab COMMAND: MESSAGE [CODE]" (last line; help hints may follow).
  const std::string tag = std::string("[") + c.expected_code + "]";
  EXPECT_NE(run.err.find(tag), std::string::npos) << c.args << "\n" << run.err;
  EXPECT_EQ(run.err.rfind("camlab", 0), 0u) << run.err;
  // stdout: exactly the JSON error.
  const auto json = nlohmann::json::parse(run.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_FALSE(json.is_discarded()) << c.args << ": stdout is not JSON:\n" << run.out;
  ASSERT_TRUE(json.contains("error")) << json.dump();
  const std::string code = json["error"].value("code", "");
  EXPECT_EQ(code, c.expected_code) << json.dump();
  EXPECT_TRUE(camlab::find_error_code(code).has_value()) << code << " is not in base/error_code.h";
  EXPECT_FALSE(json["error"].value("message", "").empty()) << json.dump();
}

INSTANTIATE_TEST_SUITE_P(
    EverySubcommand, CliErrors,
    ::testing::Values(
        Case{"optics fov --focal-mm -5 --sensor full-frame", "invalid_argument"},
        Case{"optics dof --focal-mm 50 --f-number 8 --focus-m 0.01 --coc-mm 0.03", "no_real_image"},
        Case{"optics coc --focal-mm 50 --f-number 2 --focus-m 2 --object-m 0.02", "no_real_image"},
        Case{"optics exposure --f-number 8 --shutter 1/0 --iso 100", "invalid_argument"},
        Case{"optics lens --focal-mm 50", "invalid_argument"},
        Case{"optics stops --increment fifth", "invalid_argument"},
        Case{"render --camera DIR/broken.json --scene DIR/broken.json --out DIR/out", "bad_json"},
        Case{"devices --no-libcamera --virtual DIR/broken.json", "bad_json"},
        Case{"calibrate --corners /nonexistent.vnl --imager 640x480 --board 14x10 --spacing-m 0.04 "
             "--out DIR/cam.cameramodel",
             "not_found"},
        Case{"calibrate --images DIR --board 14 --spacing-m 0.04", "invalid_argument"},
        Case{"analyze defocus DIR/not_a_capture", "not_a_capture"},
        Case{"analyze exposure DIR/not_a_capture", "not_a_capture"},
        Case{"analyze focus DIR/not_a_capture", "not_a_capture"},
        Case{"stereo triangulate --rig DIR --pixels 1,2,3,4", "io_error"},
        Case{"stereo rectify --rig DIR DIR/broken.json DIR/broken.json --out DIR/rect", "io_error"},
        Case{"optics fov --no-such-flag", "invalid_argument"}),
    [](const ::testing::TestParamInfo<Case>& info) { return "Case" + std::to_string(info.index); });

}  // namespace
