#include "analysis/lightfield/refocus_capture.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/format.h"
#include "image/capture_folder.h"
#include "image/pixel_format.h"

namespace camlab::analysis::lightfield {

namespace {

nlohmann::json distance_json(double m) {
  return std::isfinite(m) ? nlohmann::json(m) : nlohmann::json(nullptr);
}

}  // namespace

Result<std::vector<double>> focus_sweep_m(double near_m, double far_m, int frames) {
  if (frames < 2 || frames > 1000)
    return make_error("out_of_range",
                      "frames = " + std::to_string(frames) + " is out of range [2, 1000]");
  if (!(near_m > 0 && far_m > near_m))
    return make_error("out_of_range", "near_m = " + format_significant(near_m) +
                                          ", far_m = " + format_significant(far_m) +
                                          ": both must be positive, near below far (far may be "
                                          "inf)");
  std::vector<double> out;
  const double q_near = 1 / near_m, q_far = std::isfinite(far_m) ? 1 / far_m : 0.0;
  for (int i = 0; i < frames; ++i) {
    const double q = q_far + (q_near - q_far) * i / (frames - 1);
    out.push_back(q > 0 ? 1 / q : std::numeric_limits<double>::infinity());
  }
  return out;
}

nlohmann::json to_json(const RefocusResult& r) {
  return {{"focus_m", distance_json(r.focus_m)},
          {"lens_to_sensor_mm", r.lens_to_sensor_mm},
          {"magnification", r.magnification},
          {"f_number", r.aperture.f_number},
          {"effective_f_number", r.aperture.effective_f_number},
          {"mask_radius_m", r.aperture.mask_radius_m},
          {"views_used", r.aperture.views_used},
          {"view_step_px", r.view_step_px},
          {"sharp_range_m", {distance_json(r.sharp_range_m[0]), distance_json(r.sharp_range_m[1])}},
          {"border_px", r.border_px},
          {"warnings", r.warnings}};
}

Result<RefocusCaptureSummary> write_refocus_capture(const LightField& lf,
                                                    const std::vector<double>& focus_m,
                                                    const std::vector<double>& f_numbers,
                                                    const std::filesystem::path& out_dir) {
  const auto start = std::chrono::steady_clock::now();
  if (focus_m.empty()) return make_error("invalid_argument", "no focus distance to refocus at");
  std::vector<double> distances = focus_m;
  // Far to near, as a lens's focus positions run.
  std::sort(distances.begin(), distances.end(), std::greater<>());
  const std::vector<double> apertures = f_numbers.empty() ? std::vector<double>{0} : f_numbers;
  // Every pair is checked before a frame is written, so a bad value loses no work.
  const ViewGeometry g = view_geometry(lf.description);
  for (double s : distances)
    if (auto z = refocus_lens_to_sensor_mm(g, s); !z) return z.error();
  for (double n : apertures)
    if (auto a = synthetic_aperture(lf.description, n); !a) return a.error();

  nlohmann::json parameters = {{"refocused_from", lf.source.value("camera", "")},
                               {"focus_m", nlohmann::json::array()},
                               {"f_numbers", apertures}};
  for (double s : distances) parameters["focus_m"].push_back(distance_json(s));
  auto writer = image::CaptureFolderWriter::create(out_dir, "refocus", lf.source, parameters);
  if (!writer) return writer.error();
  RefocusCaptureSummary summary;
  summary.out_dir = out_dir;
  const int max_dn = (1 << lf.bit_depth) - 1;
  uint64_t sequence = 0;
  for (size_t i = 0; i < distances.size(); ++i)
    for (double n : apertures) {
      RefocusResult r;
      CAMLAB_ASSIGN(r, refocus(lf, distances[i], n));
      cv::Mat dn;
      r.image.convertTo(dn, lf.bit_depth <= 8 ? CV_8U : CV_16U, 1.0, lf.black_level_dn);
      cv::min(dn, max_dn, dn);
      image::FrameSidecar sidecar;
      sidecar.sequence = sequence++;
      sidecar.clock = "virtual";
      sidecar.pixel_format = std::string(image::mono_pixel_format(lf.bit_depth));
      sidecar.bit_depth = lf.bit_depth;
      sidecar.black_level_dn = lf.black_level_dn;
      sidecar.settings = {{"exposure_us", lf.settings.value("exposure_us", 0.0)},
                          {"gain", lf.settings.value("gain", 1.0)},
                          {"f_number", r.aperture.effective_f_number},
                          {"focus_position", static_cast<int>(i)},
                          {"focus_distance_m", distance_json(r.focus_m)},
                          {"lens_to_sensor_mm", r.lens_to_sensor_mm}};
      sidecar.labels = {{"refocus_index", i}, {"synthetic_f_number", r.aperture.f_number}};
      auto added = writer->add_frame(dn, sidecar);
      if (!added) return added.error();
      summary.frames_json.push_back(to_json(r));
      for (const std::string& w : r.warnings)
        if (std::find(summary.warnings.begin(), summary.warnings.end(), w) ==
            summary.warnings.end())
          summary.warnings.push_back(w);
      ++summary.frames;
    }
  if (Status s = writer->finish(); !s) return s.error();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace camlab::analysis::lightfield
