#include "calib/rig/rig_folder.h"

#include <fstream>

#include <nlohmann/json.hpp>

#include "base/format.h"
#include "calib/mrcal_api.h"

namespace camlab::calib {

namespace fs = std::filesystem;

namespace {

Result<RigCamera> read_camera(const fs::path& file) {
  mrcal_cameramodel_t* m = mrcal_read_cameramodel_file(file.c_str());
  if (m == nullptr)
    return make_error("io_error", file.string() + ": not a .cameramodel mrcal can read");
  char name[1024] = {};
  RigCamera cam;
  const bool named = mrcal_lensmodel_name(name, sizeof name, &m->lensmodel);
  const int nparams = mrcal_lensmodel_num_params(&m->lensmodel);
  cam.model.lensmodel = name;
  cam.model.intrinsics.assign(m->intrinsics, m->intrinsics + nparams);
  cam.model.width_px = static_cast<int>(m->imagersize[0]);
  cam.model.height_px = static_cast<int>(m->imagersize[1]);
  for (int k = 0; k < 6; ++k) cam.rt_cam_ref[k] = m->rt_cam_ref[k];
  mrcal_free_cameramodel(&m);
  if (!named) return make_error("io_error", file.string() + ": a lens model mrcal cannot name");
  return cam;
}

// rig.json's uncertainty onto the cameras read from the models.
Status apply_report(const nlohmann::json& report, const fs::path& file, RigSolution* rig) {
  const auto& cameras = report.at("cameras");
  if (cameras.size() != rig->cameras.size())
    return make_error("invalid_argument",
                      format_printf("%s has %zu cameras, the folder's models %zu", file.c_str(),
                                    cameras.size(), rig->cameras.size()));
  rig->corner_sigma_px = report.value("corner_sigma_px", 0.0);
  rig->rms_px = report.value("rms_px", 0.0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    RigCamera& cam = rig->cameras[c];
    const auto& j = cameras[c];
    if (j.at("lensmodel").get<std::string>() != cam.model.lensmodel)
      return make_error(
          "invalid_argument",
          format_printf("%s: camera %zu's model is %s, its .cameramodel's %s", file.c_str(), c,
                        j.at("lensmodel").get<std::string>().c_str(), cam.model.lensmodel.c_str()));
    cam.rt_covariance = j.at("rt_cam_ref_covariance").get<std::array<double, 36>>();
    cam.rotation_sigma_deg = j.at("rotation_sigma_deg").get<std::array<double, 3>>();
    cam.translation_sigma_mm = j.at("translation_sigma_mm").get<std::array<double, 3>>();
    cam.baseline_m = j.value("baseline_m", 0.0);
    cam.baseline_sigma_mm = j.value("baseline_sigma_mm", 0.0);
    cam.rms_px = j.value("rms_px", 0.0);
  }
  if (report.contains("parameter_covariance") && report["parameter_covariance"].is_object()) {
    const auto& p = report["parameter_covariance"];
    rig->parameter_count = p.at("parameters").get<int>();
    rig->parameter_covariance = p.at("values").get<std::vector<double>>();
    if (rig->parameter_covariance.size() !=
        static_cast<size_t>(rig->parameter_count) * rig->parameter_count)
      return make_error("invalid_argument",
                        file.string() + ": parameter_covariance is not parameters^2 values");
  }
  return {};
}

}  // namespace

Result<RigSolution> read_rig_folder(const fs::path& dir) {
  RigSolution rig;
  for (int c = 0; c < kRigCamerasMax; ++c) {
    const fs::path file = dir / ("camera-" + std::to_string(c) + ".cameramodel");
    if (!fs::exists(file)) break;
    RigCamera cam;
    CAMLAB_ASSIGN(cam, read_camera(file));
    rig.cameras.push_back(std::move(cam));
  }
  if (rig.cameras.size() < 2)
    return make_error("io_error", dir.string() +
                                      ": a rig folder holds camera-0.cameramodel and "
                                      "camera-1.cameramodel at least (camlab calibrate --rig "
                                      "--out writes them)");
  const fs::path report_file = dir / "rig.json";
  if (!fs::exists(report_file)) return rig;
  std::ifstream in(report_file);
  const nlohmann::json report = nlohmann::json::parse(in, nullptr, false);
  if (report.is_discarded() || !report.is_object())
    return make_error("invalid_argument", report_file.string() + ": not JSON");
  try {
    if (Status s = apply_report(report, report_file, &rig); !s) return s.error();
  } catch (const nlohmann::json::exception& e) {
    return make_error("invalid_argument",
                      report_file.string() + ": not a rig report (" + e.what() + ")");
  }
  return rig;
}

}  // namespace camlab::calib
