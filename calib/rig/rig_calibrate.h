// A whole rig calibration, as `camlab calibrate --rig` runs it: each camera's board views
// from its own source (a folder of images, a capture folder, or a corners.vnl file), the
// views matched across cameras by file name (a rig view is the images of one name, e.g.
// view-0001.png in every camera's folder; a camera without the name, or without the board
// in it, does not see that view), the lens models (one given for all, or `auto`: each
// camera's own selection, model_selection.h, kept in the joint solve), the joint solve
// (rig_solver.h), and the files:
// camera-N.cameramodel (mrcal's format and convention: camera 0 at the reference, each file's
// extrinsics rt_cam_ref) and rig.json (the report).
//
// Reentrant.
#pragma once

#include <atomic>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/calibrate.h"
#include "calib/rig/rig_solver.h"

namespace camlab::calib {

struct RigCalibrateOptions {
  // One a camera: its source (images_dir, job_dir or corners_vnl, with the imager size for
  // corners.vnl), the board and the detector. Their model and outputs are not read.
  std::vector<CalibrateOptions> cameras;
  std::string model = "auto";  // "auto" or a mrcal LENSMODEL_... name for every camera
  bool board_warp = true;
  std::filesystem::path out_dir;  // camera-N.cameramodel and rig.json; empty: none written
  // > 0: each camera's triangulated-range uncertainty with camera 0 for a point this far
  // along camera 0's axis (rig_range.h), in the report's "range_uncertainty".
  double range_m = 0;
  // Set: an earlier rig.json of this rig, compared with this calibration (rig_drift.h), in
  // the report's "drift".
  std::filesystem::path drift_from;
  // Set (one map a camera): which frames make a rig view, by file name -> view name, as a
  // synchronised capture's rig views pair them (by start time, not by name); frames absent
  // from a camera's map are not used. Empty: views matched by file name.
  std::vector<std::map<std::string, std::string>> view_of_frame;
  const std::atomic<bool>* cancel = nullptr;
};

struct RigCalibrationRun {
  RigData data;                         // views aligned by name
  std::vector<std::string> view_names;  // per rig view
  std::vector<std::string> own_models;  // per camera with `auto`: its own selection, solved in
  RigSolution solution;
  nlohmann::json range_uncertainty = nlohmann::json::array();  // per camera 1..N-1
  nlohmann::json drift;                                        // with drift_from
  // Per camera 1..N-1: its pair with camera 0 rectified (rectification.h) and the epipolar
  // residual of the calibration's corners; the rectified pair's models are written as
  // rectified-N-0.cameramodel and rectified-N-N.cameramodel (mrcal-stereo's
  // rectified0/1.cameramodel).
  nlohmann::json rectification = nlohmann::json::array();
  nlohmann::json report;           // what rig.json holds
  std::vector<std::string> files;  // written
};

// Errors: those of read_board_views() per camera (with "camera N: " before the message),
// "imager_mismatch" is not one (cameras may differ), and solve_rig()'s.
Result<RigCalibrationRun> calibrate_rig(const RigCalibrateOptions& options);

// The report of a solved rig (rig.json): per camera its model, intrinsics, rt_cam_ref,
// baseline and the extrinsics' 1-sigma, RMS, views and corners; the views; warnings.
nlohmann::json rig_report_json(const RigCalibrationRun& run);

// The report for a person: one line a camera.
std::string rig_report_text(const RigCalibrationRun& run);

}  // namespace camlab::calib
