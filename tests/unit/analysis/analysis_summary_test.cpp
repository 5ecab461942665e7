// The summary every analysis ends with (analysis/analysis_summary.h): counts that add up
// to what the report holds, reasons carried over, the same words in text and JSON.
#include "analysis/analysis_summary.h"

#include <gtest/gtest.h>

namespace camlab::analysis {
namespace {

FrameEdge edge_with(std::string_view status) {
  FrameEdge fe;
  fe.edge.status = std::string(status);
  return fe;
}

TEST(AnalysisSummary, DefocusCountsEveryFitAndEachReasonOverChannels) {
  DefocusReport green;
  TargetDefocus t;
  t.name = "edge";
  t.frames = {edge_with(kEdgeOk), edge_with(kEdgeOk), edge_with(kEdgeClipped),
              edge_with(kEdgeNeighbourOverlap)};
  t.aperture = ApertureFit{};
  green.targets = {t};
  DefocusReport colour;
  colour.channels = {green, green};
  const nlohmann::json s = summary_json(colour);
  EXPECT_EQ(s["edge_fits"], 8);
  EXPECT_EQ(s["measured"], 4);
  EXPECT_EQ(s["left_out"]["clipped"], 2);
  EXPECT_EQ(s["left_out"]["neighbour_overlap"], 2);
  EXPECT_EQ(s["aperture_fits"], 2);
  EXPECT_EQ(s["v_curve_fits"], 0);
  const std::string text = summary_text(s);
  EXPECT_NE(text.find("4 of 8 edge fits measured"), std::string::npos) << text;
  EXPECT_NE(text.find("2 clipped"), std::string::npos) << text;
}

TEST(AnalysisSummary, ExposureNamesEachSettingLeftOut) {
  ExposureReport r;
  r.linearity.resize(5);
  for (int k = 0; k < 3; ++k) r.linearity[k].used = true;
  r.left_out = {"16000 us x gain 1: saturated", "1000 us: dark"};
  const nlohmann::json s = summary_json(r);
  EXPECT_EQ(s["settings"], 5);
  EXPECT_EQ(s["linearity_used"], 3);
  EXPECT_EQ(s["photon_transfer_used"], 0);
  ASSERT_EQ(s["left_out"].size(), 2u);
  EXPECT_EQ(s["left_out"][0], "16000 us x gain 1: saturated");
  EXPECT_NE(summary_text(s).find("2 left out"), std::string::npos);
}

TEST(AnalysisSummary, FocusCountsRegionsByStatus) {
  FocusReport r;
  r.positions = {0, 10, 20};
  r.regions.resize(3);
  r.regions[0].focus.status = std::string(kFocusOk);
  r.regions[1].focus.status = std::string(kFocusOk);
  r.regions[2].focus.status = std::string(kFocusFlat);
  const nlohmann::json s = summary_json(r);
  EXPECT_EQ(s["regions"], 3);
  EXPECT_EQ(s["regions_by_status"]["ok"], 2);
  EXPECT_EQ(s["regions_by_status"]["flat_texture"], 1);
  EXPECT_NE(summary_text(s).find("3 regions over 3 positions"), std::string::npos);
}

}  // namespace
}  // namespace camlab::analysis
