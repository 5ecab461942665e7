// Plots through gnuplot (analysis/plot.h): what reaches the script (only drawable points,
// escaped text, the colour bar's ticks), what the PNG shows (image coordinates drawn
// downwards, the size asked for), and the errors: nothing to plot, no gnuplot.
#include "analysis/plot.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>

namespace camlab::analysis {
namespace {

namespace fs = std::filesystem;

fs::path fresh(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("camlab_plot_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The centroid row of the pixels of one colour (B, G, R), or NaN when none.
double centroid_row(const cv::Mat& image, cv::Vec3b colour) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - colour[0]) + std::abs(p[1] - colour[1]) + std::abs(p[2] - colour[2]) <
          30) {
        sum += y;
        ++n;
      }
    }
  return n ? sum / n : std::nan("");
}

TEST(Plot, OnlyDrawablePointsReachTheScript) {
  PlotSpec spec;
  spec.title = "a \"quoted\" title with a \\ backslash";
  spec.log_y = true;
  PlotSeries s;
  s.label = "edge_0";  // an underscore stays an underscore (no enhanced text)
  s.x = {1, 2, 3, 4, 5};
  s.y = {10, NAN, -1, 0, 50};  // NaN, and two that a log axis cannot show
  spec.series = {s};
  int points = 0;
  const std::string script = gnuplot_script("/tmp/x.png", spec, &points);
  EXPECT_EQ(points, 2);
  EXPECT_NE(script.find("noenhanced"), std::string::npos);
  EXPECT_NE(script.find("set title \"a \\\"quoted\\\" title with a \\\\ backslash\""),
            std::string::npos)
      << script;
  EXPECT_NE(script.find("set logscale y 10"), std::string::npos);
  EXPECT_EQ(count_of(script, "\n1 10\n") + count_of(script, "\n5 50\n"), 2) << script;

  const fs::path dir = fresh("drawable");
  ASSERT_TRUE(write_plot(dir / "p.png", spec).ok());
  const cv::Mat png = cv::imread((dir / "p.png").string());
  EXPECT_EQ(png.cols, spec.width_px);
  EXPECT_EQ(png.rows, spec.height_px);
  EXPECT_TRUE(fs::exists(dir / "p.gp"));  // the script that drew it, to rerun
  fs::remove_all(dir);
}

TEST(Plot, ImageCoordinatesAreDrawnDownwards) {
  // A red point at y = 0 and a blue one at y = 10: above it on a y-down panel, below it on
  // an ordinary one.
  const fs::path dir = fresh("y_down");
  for (bool y_down : {true, false}) {
    PlotSpec spec;
    spec.y_down = y_down;
    PlotSeries red, blue;
    red.x = {0}, red.y = {0}, red.color_bgr = 0x0000ff, red.marker_px = 8;
    blue.x = {0}, blue.y = {10}, blue.color_bgr = 0xff0000, blue.marker_px = 8;
    spec.series = {red, blue};
    spec.x_range = {{-1, 1}};
    spec.y_range = {{-1, 11}};
    ASSERT_TRUE(write_plot(dir / "p.png", spec).ok());
    const cv::Mat png = cv::imread((dir / "p.png").string());
    const double red_row = centroid_row(png, {0, 0, 255});
    const double blue_row = centroid_row(png, {255, 0, 0});
    ASSERT_TRUE(std::isfinite(red_row) && std::isfinite(blue_row));
    EXPECT_EQ(red_row < blue_row, y_down) << red_row << " " << blue_row;
  }
  fs::remove_all(dir);
}

TEST(Plot, ALogColourBarWithinADecadeGetsTicksAtOneTwoFive) {
  PlotSpec spec;
  PlotHeatmap h;
  h.cols = 2, h.rows = 2;
  h.values = {0.03, 0.09, NAN, 0.25};
  h.log_scale = true;
  h.label = "px";
  spec.heatmap = h;
  int points = 0;
  const std::string script = gnuplot_script("/tmp/h.png", spec, &points);
  EXPECT_NE(script.find("set cbtics (0.05, 0.1, 0.2)"), std::string::npos) << script;
  const fs::path dir = fresh("heat");
  EXPECT_TRUE(write_plot(dir / "h.png", spec).ok());  // a NaN cell is left blank, no error
  fs::remove_all(dir);
}

TEST(Plot, NothingToPlotAndNoGnuplotAreErrors) {
  const fs::path dir = fresh("errors");
  PlotSpec empty;
  PlotSeries nan;
  nan.x = {NAN};
  nan.y = {1};
  empty.series = {nan};
  auto none = write_plot(dir / "e.png", empty);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, "empty_plot");

  PlotSpec one;
  PlotSeries p;
  p.x = {1};
  p.y = {1};
  one.series = {p};
  const std::string path = getenv("PATH") ? getenv("PATH") : "";
  setenv("PATH", (dir / "nowhere").c_str(), 1);
  auto missing = write_plot(dir / "m.png", one);
  setenv("PATH", path.c_str(), 1);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, "plotter_failed");
  EXPECT_NE(missing.error().message.find("install"), std::string::npos) << missing.error().message;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace camlab::analysis
