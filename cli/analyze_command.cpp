// `camlab analyze defocus|exposure|focus DIR`: parses arguments, runs analysis::analyze()
// (src/analysis/analyze_folder.h: the measurement, its JSON report, a text summary and the
// plots) and prints the summary or the JSON; --report also writes the JSON.
// `camlab analyze sfr IMAGE`: the slanted-edge SFR of every edge in one image
// (src/analysis/sfr/sfr_image.h).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/analyze_folder.h"
#include "analysis/sfr/sfr_image.h"
#include "command_errors.h"
#include "commands.h"

namespace camlab::cli {
namespace {

struct AnalyzeArgs {
  std::string dir;
  bool json = false;
  std::string report_path;
  std::string plots_dir;
  double baseline_sigma_px = -1;
  double min_diameter_px = 1.0;
  double acceptable_coc_px = 2.0;
  int threads = 2;
  int region_px = 32;
  int window_px = 9;
  double pixel_um = 0;
  double half_width_px = 24;
  double min_edge_px = 40;
  double focus_step_mm = 0;
  std::string transfer = "auto";
};

// The report to --report, then the JSON (--json) or the text summary to stdout.
void emit(const CommandErrors& errors, const AnalyzeArgs& args, const nlohmann::json& report,
          const std::string& text) {
  if (!args.report_path.empty()) {
    std::ofstream out(args.report_path);
    out << report.dump(2) << "\n";
    if (!out) errors.fail("io_error", "cannot write the report to " + args.report_path);
  }
  if (args.json)
    std::printf("%s\n", report.dump(2).c_str());
  else
    std::printf("%s", text.c_str());
}

void run(const char* kind, const AnalyzeArgs& args) {
  const CommandErrors errors("camlab analyze", args.json);
  analysis::AnalyzeOptions o;
  o.defocus.baseline_sigma_px = args.baseline_sigma_px;
  o.defocus.min_diameter_px = args.min_diameter_px;
  o.defocus.acceptable_coc_px = args.acceptable_coc_px;
  o.defocus.threads = args.threads;
  o.focus.region_px = args.region_px;
  o.focus.window_px = args.window_px;
  o.plots_dir = args.plots_dir;
  const auto result = errors.take(analysis::analyze(kind, args.dir, o));
  emit(errors, args, result.report, result.text);
}

void run_sfr(const AnalyzeArgs& args) {
  const CommandErrors errors("camlab analyze", args.json);
  analysis::SfrImageOptions o;
  o.pixel_pitch_um = args.pixel_um;
  o.sfr.half_width_px = args.half_width_px;
  o.min_edge_length_px = args.min_edge_px;
  o.transfer = args.transfer == "linear" ? analysis::ImageTransfer::kLinear
               : args.transfer == "srgb" ? analysis::ImageTransfer::kSrgb
                                         : analysis::ImageTransfer::kAuto;
  if (std::filesystem::is_directory(args.dir)) {
    // A capture folder: the same run as camlabd's analysis job of kind "sfr".
    analysis::AnalyzeOptions folder;
    folder.sfr = o;
    const auto result = errors.take(analysis::analyze("sfr", args.dir, folder));
    return emit(errors, args, result.report, result.text);
  }
  const auto result = errors.take(analysis::analyze_sfr_image(args.dir, o));
  emit(errors, args, result.report, result.text);
}

void run_lensmap(const AnalyzeArgs& args) {
  const CommandErrors errors("camlab analyze", args.json);
  analysis::AnalyzeOptions o;
  o.sfr.pixel_pitch_um = args.pixel_um;
  o.sfr.sfr.half_width_px = args.half_width_px;
  o.sfr.min_edge_length_px = args.min_edge_px;
  o.lensmap.pixel_pitch_um = args.pixel_um;
  o.lensmap.extension_mm_per_step = args.focus_step_mm;
  o.plots_dir = args.plots_dir;
  const auto result = errors.take(analysis::analyze("lensmap", args.dir, o));
  emit(errors, args, result.report, result.text);
}

void add_common(CLI::App* sub, AnalyzeArgs* args) {
  sub->add_option("DIR", args->dir, "capture folder")->required()->check(CLI::ExistingDirectory);
  sub->add_flag("--json", args->json, "print the report as JSON");
  sub->add_option("--report", args->report_path, "also write the JSON report to this file");
  sub->add_option("--plots", args->plots_dir, "write PNG plots into this folder");
}

}  // namespace

void register_analyze_command(CLI::App& app) {
  auto args = std::make_shared<AnalyzeArgs>();
  CLI::App* analyze = app.add_subcommand(
      "analyze",
      "measure optics from a capture folder (defocus, exposure, focus) or an image (sfr)");
  analyze->require_subcommand(1);

  CLI::App* defocus = analyze->add_subcommand(
      "defocus",
      "blur-disk diameter per slanted edge; C = k/N over an aperture series, the "
      "V-curve over a focus sweep");
  add_common(defocus, args.get());
  defocus
      ->add_option("--baseline-sigma", args->baseline_sigma_px,
                   "in-focus Gaussian blur of the lens in px (default: from the capture)")
      ->check(CLI::Range(0.0, 50.0));
  defocus
      ->add_option("--min-diameter", args->min_diameter_px, "smallest blur (px) used in the fits")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  defocus
      ->add_option("--coc", args->acceptable_coc_px, "acceptable CoC (px) for the depth of field")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1000.0));
  defocus->add_option("--threads", args->threads, "frames measured in parallel")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  defocus->callback([args] { run("defocus", *args); });

  CLI::App* exposure = analyze->add_subcommand(
      "exposure", "linearity in T x gain, EMVA 1288 photon transfer from frame pairs, HDR merge");
  add_common(exposure, args.get());
  exposure->callback([args] { run("exposure", *args); });

  CLI::App* focus = analyze->add_subcommand(
      "focus", "focus stack: best focus per region and pixel, depth map, all-in-focus image");
  add_common(focus, args.get());
  focus->add_option("--region", args->region_px, "region size in px")
      ->capture_default_str()
      ->check(CLI::Range(4, 4096));
  focus->add_option("--window", args->window_px, "per-pixel measure window in px (odd)")
      ->capture_default_str()
      ->check(CLI::Range(1, 255));
  focus->callback([args] { run("focus", *args); });

  CLI::App* sfr = analyze->add_subcommand(
      "sfr",
      "ISO 12233 slanted-edge SFR of every straight edge in an image or in each frame of a "
      "capture folder: MTF50 with its standard error (from the edge's own noise), MTF30, "
      "MTF10 in cycles/px across the edge (and lp/mm with --pixel-um), each edge's orientation "
      "in the "
      "field (meridional, sagittal) relative to the image centre; edges within 2 deg of a "
      "pixel axis, clipped, or wider than the window are flagged, not measured");
  sfr->add_option("IMAGE", args->dir,
                  "image file (PNG, JPEG, TIFF; 8 or 16 bits; colour as luminance), or a capture "
                  "folder: every frame, with its settings (MTF50 through focus and aperture)")
      ->required()
      ->check(CLI::ExistingPath);
  sfr->add_flag("--json", args->json, "print the report as JSON (with each edge's SFR curve)");
  sfr->add_option("--report", args->report_path, "also write the JSON report to this file");
  sfr->add_option("--pixel-um", args->pixel_um, "pixel pitch in micrometres: MTF50 in lp/mm too")
      ->check(CLI::Range(0.1, 100.0));
  sfr->add_option("--half-width", args->half_width_px,
                  "px each side of the edge read for its ESF (at least 3 blur diameters across)")
      ->capture_default_str()
      ->check(CLI::Range(4.0, 256.0));
  sfr->add_option("--min-edge", args->min_edge_px, "shortest edge measured (px)")
      ->capture_default_str()
      ->check(CLI::Range(16.0, 100000.0));
  sfr->add_option("--transfer", args->transfer,
                  "how an image file's values relate to light (the SFR is measured on linear "
                  "values): auto (8-bit files sRGB-encoded, 16-bit linear), linear, srgb; "
                  "capture folders are read as stored")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "linear", "srgb"}));
  sfr->callback([args] { run_sfr(*args); });

  CLI::App* lensmap = analyze->add_subcommand(
      "lensmap",
      "the lens across its field from a focus sweep (a capture with 5 or more focus_position "
      "values, at one or more f-numbers) of a chart of slanted edges: each edge's best focus "
      "(the vertex of 1/MTF50^2 through focus), then per f-number the best-focus surface over "
      "the field: focus on the axis, tilt, field curvature, and the sagittal and meridional "
      "curvatures apart (astigmatism), in focus steps and, with the lens's extension per step "
      "and the pixel pitch, in micrometres at the sensor and degrees");
  lensmap->add_option("DIR", args->dir, "capture folder of the focus sweep")
      ->required()
      ->check(CLI::ExistingDirectory);
  lensmap->add_flag("--json", args->json, "print the report as JSON");
  lensmap->add_option("--report", args->report_path, "also write the JSON report to this file");
  lensmap->add_option("--plots", args->plots_dir,
                      "write PNG plots into this folder: per f-number the best-focus surface "
                      "over the imager and every edge's MTF50 through focus");
  lensmap
      ->add_option("--pixel-um", args->pixel_um,
                   "pixel pitch in micrometres (default: the capture's camera spec's)")
      ->check(CLI::Range(0.1, 100.0));
  lensmap
      ->add_option("--focus-step-mm", args->focus_step_mm,
                   "lens movement per focus_position unit in mm (default: the capture's "
                   "camera spec's lens.focus.extension_mm_per_step)")
      ->check(CLI::Range(1e-6, 10.0));
  lensmap
      ->add_option("--half-width", args->half_width_px,
                   "px each side of an edge read for its ESF (3 blur diameters at the "
                   "sweep's ends)")
      ->capture_default_str()
      ->check(CLI::Range(4.0, 256.0));
  lensmap->add_option("--min-edge", args->min_edge_px, "shortest edge measured (px)")
      ->capture_default_str()
      ->check(CLI::Range(16.0, 100000.0));
  lensmap->callback([args] { run_lensmap(*args); });
}

}  // namespace camlab::cli
