// `camlab lightfield` end to end through the built executable: render a small light field
// of the example scene, refocus it, make a focus stack that `camlab analyze focus` reads,
// measure depth, decode its lenslet image; and the commands' errors: one line naming the
// value and the range, a code, exit status 2, the same as JSON with --json.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "image/lightfield_folder.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;
using nlohmann::json;

class CliLightField : public ::testing::Test {
 protected:
  // One light field for the suite: the example camera at 96 x 64 px, 5 x 5 views, a
  // square microlens grid, the example scene.
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("camlab_cli_lightfield_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ifstream in(std::string(CAMLAB_SOURCE_DIR) +
                     "/mock_device/examples/camera_lightfield_9x9.json");
    json camera = json::parse(in);
    camera["sensor"]["width_px"] = 96;
    camera["sensor"]["height_px"] = 64;
    camera["lightfield"]["views"] = {5, 5};
    std::ofstream(dir_ / "camera.json") << camera.dump();
    const auto run =
        run_cli("lightfield render --camera " + (dir_ / "camera.json").string() + " --scene " +
                CAMLAB_SOURCE_DIR + "/mock_device/examples/scene_lightfield_planes.json --out " +
                (dir_ / "lf").string() + " --json");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    render_ = json::parse(run.out);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string at(const char* name) { return (dir_ / name).string(); }
  static fs::path dir_;
  static json render_;
};
fs::path CliLightField::dir_;
json CliLightField::render_;

TEST_F(CliLightField, RenderWritesAFolderOfViewsAndALensletImage) {
  EXPECT_EQ(render_["views"], 25);  // 5 x 5 cells: even the corners reach into the disk
  EXPECT_EQ(render_["lenslet_size"], json({2 * 2 + 96 * 5, 2 * 2 + 64 * 5}));
  auto folder = camlab::image::LightFieldFolder::open(at("lf"));
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_TRUE(folder->description().lenslet.has_value());
  EXPECT_TRUE(folder->load_depth_truth().ok());
}

TEST_F(CliLightField, RefocusStackIsReadByAnalyzeFocus) {
  auto run = run_cli("lightfield refocus " + at("lf") + " --focus-m 0.6,1.6 --f-number 2,4 --out " +
                     at("refocused") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json out = json::parse(run.out);
  ASSERT_EQ(out["frames"].size(), 4u);
  EXPECT_EQ(out["frames"][0]["focus_m"], 1.6);  // far to near, as focus positions run
  EXPECT_NEAR(out["frames"][3]["effective_f_number"].get<double>(), 4.0, 1e-6);
  run = run_cli("lightfield stack " + at("lf") + " --near-m 0.5 --far-m 2 --frames 9 --out " +
                at("stack"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("wrote 9 frames"), std::string::npos) << run.out;
  run = run_cli("analyze focus " + at("stack") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json focus = json::parse(run.out);
  EXPECT_EQ(focus["frames"], 9);
  EXPECT_GT(focus["regions_ok"].get<int>(), 0);
}

TEST_F(CliLightField, DepthAndDecode) {
  auto run = run_cli("lightfield depth " + at("lf") + " --out " + at("depth") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json depth = json::parse(run.out);
  EXPECT_GT(depth["ok_share"].get<double>(), 0.2);
  const double median = depth["depth_m_quantiles"]["median"];
  EXPECT_GT(median, 0.55);  // the scene's planes lie between 0.6 and 1.6 m
  EXPECT_LT(median, 1.65);
  EXPECT_TRUE(fs::exists(at("depth") + "/depth_m.pfm"));
  run = run_cli("lightfield decode " + at("lf") + " --out " + at("decoded") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json decoded = json::parse(run.out);
  EXPECT_EQ(decoded["views_per_side"], 5);
  EXPECT_EQ(decoded["lattice"]["layout"], "square");
  EXPECT_NEAR(decoded["lattice"]["pitch_px"].get<double>(), 5, 1e-6);
}

TEST_F(CliLightField, ErrorsNameTheValueAndTheRange) {
  // A capture folder that is not a light field: one refocused frame (each test is a
  // process of its own: nothing of the other tests' folders is here).
  ASSERT_EQ(
      run_cli("lightfield refocus " + at("lf") + " --focus-m 1 --out " + at("not_lf")).exit_code,
      0);
  struct Case {
    std::string args, code, says;
  };
  const Case cases[] = {
      {"lightfield refocus " + at("lf") + " --focus-m -1 --out " + at("e1"), "out_of_range",
       "behind the lens"},
      {"lightfield refocus " + at("lf") + " --focus-m 0.005 --out " + at("e2"), "no_real_image",
       "focal length"},
      {"lightfield refocus " + at("lf") + " --focus-m 1 --f-number 1.4 --out " + at("e3"),
       "out_of_range", "[2, "},
      {"lightfield depth " + at("lf") + " --near-m 2 --far-m 1", "invalid_argument",
       "near below far"},
      {"lightfield stack " + at("lf") + " --near-m 1 --far-m 2 --frames 1 --out " + at("e4"),
       "invalid_argument", "frames"},
      {"lightfield decode " + at("not_lf") + " --out " + at("e5"), "not_found",
       "not a light field"},
  };
  for (const Case& c : cases) {
    const auto run = run_cli(c.args + " --json");
    EXPECT_EQ(run.exit_code, 2) << c.args << "\n" << run.err;
    EXPECT_NE(run.err.find("[" + c.code + "]"), std::string::npos) << c.args << "\n" << run.err;
    EXPECT_NE(run.err.find(c.says), std::string::npos) << c.args << "\n" << run.err;
    const json j = json::parse(run.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << run.out;
    EXPECT_EQ(j["error"]["code"], c.code);
  }
}

}  // namespace
