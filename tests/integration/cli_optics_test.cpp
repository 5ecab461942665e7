// `camlab optics ...` end to end: runs the built CLI (CAMLAB_CLI_PATH), parses its JSON
// and checks it against the quoted figures and closed forms computed here, and checks that
// bad input exits non-zero with a message that says what was wrong.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using nlohmann::json;

using camlab::testing::CliRun;
using camlab::testing::run_cli;

// Runs a command that must succeed and returns its JSON.
json run_json(const std::string& args) {
  const CliRun run = run_cli(args + " --json");
  EXPECT_EQ(run.exit_code, 0) << args << "\n" << run.err;
  const json document = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(document.is_discarded()) << args << "\n" << run.out;
  return document;
}

double round_to(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(CliOptics, FullFrameDiagonalFieldOfView) {
  const json fov17 = run_json("optics fov --focal-mm 17 --sensor full-frame");
  const json fov50 = run_json("optics fov --focal-mm 50 --sensor full-frame");
  const json fov200 = run_json("optics fov --focal-mm 200 --sensor ff");
  EXPECT_DOUBLE_EQ(round_to(fov17["dfov_deg"].get<double>(), 1), 103.7);
  EXPECT_DOUBLE_EQ(round_to(fov50["dfov_deg"].get<double>(), 1), 46.8);
  EXPECT_DOUBLE_EQ(round_to(fov200["dfov_deg"].get<double>(), 2), 12.35);
  EXPECT_EQ(fov50["sensor"]["name"], "full-frame");
  EXPECT_EQ(fov50["sensor"]["width_mm"], 36.0);
  EXPECT_EQ(fov50["sensor"]["height_mm"], 24.0);
  EXPECT_DOUBLE_EQ(fov50["crop_factor"].get<double>(), 1.0);
  // Horizontal: 2 atan(18 / 50).
  const double hfov_deg = 2.0 * std::atan(18.0 / 50.0) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(fov50["hfov_deg"].get<double>(), hfov_deg, 1e-9);
}

TEST(CliOptics, ApsCCropFactorAndCustomSensor) {
  const json apsc = run_json("optics fov --focal-mm 35 --sensor aps-c");
  EXPECT_DOUBLE_EQ(round_to(apsc["crop_factor"].get<double>(), 2), 1.52);
  EXPECT_NEAR(apsc["equivalent_focal_mm"].get<double>(),
              35.0 * std::hypot(36.0, 24.0) / std::hypot(23.6, 15.8), 1e-9);
  const json custom = run_json("optics fov --focal-mm 35 --sensor-mm 23.6x15.8");
  EXPECT_EQ(custom["sensor"]["name"], "custom");
  EXPECT_DOUBLE_EQ(custom["dfov_deg"].get<double>(), apsc["dfov_deg"].get<double>());
}

TEST(CliOptics, DepthOfFieldMatchesLectureForms) {
  const double f = 50.0, n = 8.0, s = 3000.0, c = 0.03;  // mm
  const json dof = run_json("optics dof --focal-mm 50 --f-number 8 --focus-m 3 --coc-mm 0.03");
  // D_N = D_S f^2 / (f^2 + N C (D_S - f)), D_F = D_S f^2 / (f^2 - N C (D_S - f)), in m.
  const double near_m = s * f * f / (f * f + n * c * (s - f)) / 1000.0;
  const double far_m = s * f * f / (f * f - n * c * (s - f)) / 1000.0;
  EXPECT_NEAR(dof["near_m"].get<double>(), near_m, 1e-12);
  EXPECT_NEAR(dof["far_m"].get<double>(), far_m, 1e-12);
  EXPECT_NEAR(dof["total_m"].get<double>(), far_m - near_m, 1e-12);
  EXPECT_NEAR(dof["hyperfocal_m"].get<double>(), (f * f / (n * c) + f) / 1000.0, 1e-12);
}

TEST(CliOptics, InfiniteFarLimitIsJsonNullAndTextInf) {
  // Focus at infinity: near = H - f, far and total infinite.
  const json at_infinity =
      run_json("optics dof --focal-mm 50 --f-number 8 --focus-m inf --coc-mm 0.03");
  EXPECT_TRUE(at_infinity["far_m"].is_null());
  EXPECT_TRUE(at_infinity["total_m"].is_null());
  EXPECT_TRUE(at_infinity["focus_m"].is_null());
  EXPECT_NEAR(at_infinity["near_m"].get<double>(), 2500.0 / 0.24 / 1000.0, 1e-12);
  // Focus beyond H (10.47 m): far infinite too.
  const json beyond = run_json("optics dof --focal-mm 50 --f-number 8 --focus-m 20 --coc-mm 0.03");
  EXPECT_TRUE(beyond["far_m"].is_null());
  EXPECT_LT(beyond["near_m"].get<double>(), 20.0);
  const CliRun text = run_cli("optics dof --focal-mm 50 --f-number 8 --focus-m 20 --coc-mm 0.03");
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_TRUE(contains(text.out, "far_m")) << text.out;
  EXPECT_TRUE(contains(text.out, "inf")) << text.out;
}

TEST(CliOptics, CircleOfConfusionAndDiffraction) {
  // Object at focus: exactly 0, below the Airy disk.
  const json in_focus =
      run_json("optics coc --focal-mm 50 --f-number 8 --focus-m 3 --object-m 3 --pixel-um 4");
  EXPECT_EQ(in_focus["coc_mm"].get<double>(), 0.0);
  EXPECT_EQ(in_focus["coc_px"].get<double>(), 0.0);
  EXPECT_TRUE(in_focus["below_diffraction"].get<bool>());
  EXPECT_NEAR(in_focus["airy_diameter_um"].get<double>(), 2.44 * 0.55 * 8.0, 1e-12);
  // Object at 10 m: C = (f^2 / N) |z_o - s| / (z_o (s - f)).
  const json behind =
      run_json("optics coc --focal-mm 50 --f-number 8 --focus-m 3 --object-m 10 --pixel-um 4");
  const double coc_mm = 2500.0 / 8.0 * 7000.0 / (10000.0 * 2950.0);
  EXPECT_NEAR(behind["coc_mm"].get<double>(), coc_mm, 1e-15);
  EXPECT_NEAR(behind["coc_px"].get<double>(), coc_mm * 1000.0 / 4.0, 1e-12);
  EXPECT_FALSE(behind["below_diffraction"].get<bool>());
}

TEST(CliOptics, ExposureEquivalents) {
  const json exposure = run_json(
      "optics exposure --f-number 8 --shutter 1/125 --iso 100 --to-f-number 4 --to-iso 200");
  EXPECT_NEAR(exposure["ev"].get<double>(), std::log2(64.0 * 125.0), 1e-12);
  EXPECT_NEAR(exposure["ev100"].get<double>(), std::log2(64.0 * 125.0), 1e-12);
  EXPECT_NEAR(exposure["relative_exposure"].get<double>(), 1.0 / 125.0 / 64.0, 1e-18);
  // f/8 -> f/4 is two stops more light, ISO 200 one more: 1/1000 s.
  EXPECT_NEAR(exposure["equivalent"]["exposure_s"].get<double>(), 1.0 / 1000.0, 1e-15);
  const json& table = exposure["equivalents"];
  ASSERT_EQ(table.size(), 11u);
  EXPECT_EQ(table.front()["f_number"], 1.0);
  EXPECT_EQ(table.back()["f_number"], 32.0);
  for (const json& row : table) {  // same light: T gain / N^2 constant
    const double n = row["f_number_exact"].get<double>();
    EXPECT_NEAR(row["exposure_s"].get<double>() * 2.0 / (n * n) * 125.0 * 64.0, 1.0, 1e-12);
  }
  const json by_us = run_json("optics exposure --f-number 8 --exposure-us 8000");
  EXPECT_DOUBLE_EQ(by_us["ev"].get<double>(), exposure["ev"].get<double>());
}

TEST(CliOptics, LensEquationAndStops) {
  const json two_f = run_json("optics lens --focal-mm 50 --object-m 0.1");
  EXPECT_DOUBLE_EQ(two_f["image_distance_mm"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(two_f["magnification"].get<double>(), 1.0);
  const json at_f = run_json("optics lens --focal-mm 50 --lens-to-sensor-mm 50");
  EXPECT_TRUE(at_f["focus_distance_m"].is_null());
  const json extended = run_json("optics lens --focal-mm 50 --lens-to-sensor-mm 52");
  EXPECT_NEAR(extended["focus_distance_m"].get<double>(), 50.0 * 52.0 / 2.0 / 1000.0, 1e-12);
  const json thirds = run_json("optics stops --increment third");
  ASSERT_EQ(thirds["stops"].size(), 31u);
  EXPECT_EQ(thirds["stops"][1]["marked"], 1.1);
  EXPECT_EQ(thirds["stops"][30]["marked"], 32.0);
}

TEST(CliOptics, NegativeFocalLengthIsRejected) {
  const CliRun run = run_cli("optics fov --focal-mm -5 --sensor ff --json");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_TRUE(contains(run.err, "--focal-mm")) << run.err;
  EXPECT_TRUE(contains(run.err, "must be finite and > 0")) << run.err;
  const CliRun nan = run_cli("optics dof --focal-mm nan --f-number 8 --focus-m 3 --coc-mm 0.03");
  EXPECT_NE(nan.exit_code, 0);
  EXPECT_TRUE(contains(nan.err, "--focal-mm")) << nan.err;
}

TEST(CliOptics, FocusInsideFocalLengthIsNoRealImage) {
  const CliRun run = run_cli("optics dof --focal-mm 50 --f-number 8 --focus-m 0.04 --coc-mm 0.03");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "camlab optics dof: focus_mm = 40 must be > focal_mm = 50"))
      << run.err;
  EXPECT_TRUE(contains(run.err, "no real image")) << run.err;
  // With --json the error object is on stdout too.
  const CliRun json_run =
      run_cli("optics coc --focal-mm 50 --f-number 8 --focus-m 3 --object-m 0.02 --json");
  EXPECT_EQ(json_run.exit_code, 2);
  const json error = json::parse(json_run.out, nullptr, false);
  ASSERT_FALSE(error.is_discarded()) << json_run.out;
  EXPECT_EQ(error["error"]["code"], "no_real_image");
  EXPECT_TRUE(contains(json_run.err, "camlab optics coc: object_mm = 20")) << json_run.err;
}

TEST(CliOptics, OtherBadInputsNameTheProblem) {
  const CliRun unknown = run_cli("optics fov --focal-mm 50 --sensor super35");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_TRUE(contains(unknown.err, "unknown sensor format \"super35\"")) << unknown.err;
  const CliRun no_sensor = run_cli("optics fov --focal-mm 50");
  EXPECT_EQ(no_sensor.exit_code, 2);
  EXPECT_TRUE(contains(no_sensor.err, "--sensor")) << no_sensor.err;
  const CliRun shutter = run_cli("optics exposure --f-number 8 --shutter 1/0");
  EXPECT_EQ(shutter.exit_code, 2);
  EXPECT_TRUE(contains(shutter.err, "camlab optics exposure: --shutter")) << shutter.err;
  const CliRun zero_coc = run_cli("optics dof --focal-mm 50 --f-number 8 --focus-m 3 --coc-mm 0");
  EXPECT_NE(zero_coc.exit_code, 0);
  EXPECT_TRUE(contains(zero_coc.err, "--coc-mm")) << zero_coc.err;
}

}  // namespace
