// The one check of a calibration request (calib/calibration_request.h) and the lens-model
// limits behind it (lens_model.h): every rule gives its one code, names its limit, and a
// model that would overflow or stall mrcal's solve is refused before any solve.
#include "calib/calibration_request.h"

#include <gtest/gtest.h>

#include "calib/lens_model.h"
#include "calib/solver.h"

namespace camlab::calib {
namespace {

CalibrateOptions good_request() {
  CalibrateOptions o;
  o.images_dir = "/tmp";
  o.board = {14, 10, 0.04};
  return o;
}

std::string code_of(const CalibrateOptions& o) {
  const Status s = check_calibration_request(o);
  return s.ok() ? "ok" : std::string(name_of(s.error().code));
}

TEST(CalibrationRequest, AGoodRequestPasses) {
  EXPECT_EQ(code_of(good_request()), "ok");
  CalibrateOptions o = good_request();
  o.model = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=30_Ny=20_fov_x_deg=170";
  o.pixel_pitch_um = 3;
  EXPECT_EQ(code_of(o), "ok");
  o.model = "SPLINED_STEREOGRAPHIC";  // prefix optional, default grid
  EXPECT_EQ(code_of(o), "ok");
}

TEST(CalibrationRequest, EachRuleHasItsCode) {
  CalibrateOptions o = good_request();
  o.job_dir = "/tmp";  // two sources
  EXPECT_EQ(code_of(o), "invalid_argument");

  o = good_request();
  o.board.cols = 1;
  EXPECT_EQ(code_of(o), "out_of_range");
  o.board.cols = 101;
  EXPECT_EQ(code_of(o), "out_of_range");

  for (double spacing : {0.0, -1.0, 1e-300, 5e-7, 10.5, std::nan("")}) {
    o = good_request();
    o.board.spacing_m = spacing;
    EXPECT_EQ(code_of(o), "out_of_range") << spacing;
  }
  for (double pitch : {1e-300, 0.1, 101.0, -3.0}) {
    o = good_request();
    o.pixel_pitch_um = pitch;
    EXPECT_EQ(code_of(o), "out_of_range") << pitch;
  }

  o = good_request();
  o.detector = "harris";
  EXPECT_EQ(code_of(o), "invalid_argument");
  o.detector = "mrgingham";  // 14 x 10 is not square
  EXPECT_EQ(code_of(o), "unsupported");
  o.detector = "charuco";  // no markers
  EXPECT_EQ(code_of(o), "invalid_argument");
  o.detector = "auto";
  o.charuco_dictionary = "DICT_4X4_50";  // markers without charuco
  EXPECT_EQ(code_of(o), "invalid_argument");

  o = good_request();
  o.model = "LENSMODEL_NOPE";
  EXPECT_EQ(code_of(o), "bad_lensmodel");
}

TEST(CalibrationRequest, CharucoMarkersThatOpenCvWouldAssertOnAreRefused) {
  CalibrateOptions o = good_request();
  o.detector = "charuco";
  o.charuco_dictionary = "DICT_4X4_250";
  o.charuco_marker_m = 0.03;
  EXPECT_EQ(code_of(o), "ok");
  // Smaller than the square in double, equal in float: OpenCV's float assertion.
  o.charuco_marker_m = 0.04 * (1 - 1e-12);
  EXPECT_EQ(code_of(o), "out_of_range");
  o.charuco_marker_m = 1e-300;
  EXPECT_EQ(code_of(o), "out_of_range");
  o.charuco_marker_m = 0.05;
  EXPECT_EQ(code_of(o), "out_of_range");
}

TEST(LensModelLimits, HostileSplinesAreRefusedNamingTheLimit) {
  struct Case {
    const char* model;
    const char* code;
  };
  for (const Case& c : {
           // 8 M parameters: overflowed mrcal's stack (SIGSEGV) in camlabd and camlab.
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2000_Ny=2000_fov_x_deg=170",
                "out_of_range"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=550_Ny=550_fov_x_deg=170",
                "out_of_range"},
           // Minutes of solve and 1.5 GB.
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=400_Ny=300_fov_x_deg=170",
                "out_of_range"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=60_Ny=45_fov_x_deg=170",
                "out_of_range"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=40_Ny=40_fov_x_deg=170",
                "out_of_range"},  // each side allowed, the total is not
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=7_Nx=16_Ny=10_fov_x_deg=170",
                "out_of_range"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=359",
                "out_of_range"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2_Ny=10_fov_x_deg=170", "out_of_range"},
           // 65540 read into mrcal's 16 bits is 4: refused as written, not wrapped.
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=65540_Ny=10_fov_x_deg=170",
                "bad_lensmodel"},
           Case{"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=016_Ny=10_fov_x_deg=170",
                "bad_lensmodel"},
       }) {
    auto count = lensmodel_param_count(c.model);
    ASSERT_FALSE(count.ok()) << c.model;
    EXPECT_EQ(name_of(count.error().code), std::string(c.code)) << c.model;
    if (std::string(c.code) == "out_of_range") {
      EXPECT_NE(count.error().message.find("["), std::string::npos) << count.error().message;
    }
  }
  EXPECT_EQ(
      *lensmodel_param_count("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=30_Ny=30_fov_x_deg=300"),
      4 + 2 * 900);
  // A tall imager's default grid stays within the limits.
  auto tall = configured_lensmodel("LENSMODEL_SPLINED_STEREOGRAPHIC", 400, 1600, 90);
  ASSERT_TRUE(tall.ok()) << tall.error().message;
  EXPECT_TRUE(lensmodel_param_count(*tall).ok()) << *tall;
}

TEST(LensModelLimits, TheSolveRefusesAHostileModelBeforeRunningIt) {
  CalibrationData data;
  data.board = {10, 10, 0.04};
  data.imager_width_px = 1280;
  data.imager_height_px = 800;
  // No views at all: had the model been accepted, the solve would fail later for want of
  // views ("too_few_views"); the limit is checked first.
  SolveOptions options;
  options.lensmodel = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=2000_Ny=2000_fov_x_deg=170";
  auto solved = solve(data, options);
  ASSERT_FALSE(solved.ok());
  EXPECT_EQ(name_of(solved.error().code), std::string("out_of_range")) << solved.error().message;
}

}  // namespace
}  // namespace camlab::calib
