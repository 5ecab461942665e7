// POST /v1/calibrations and POST /v1/analyses: validate the request, resolve its source
// (a finished capture job, or a capture folder inside the data folder), store a
// normalised job and queue it on the compute worker (service/jobs/compute_jobs.h).
#include <algorithm>

#include "analysis/capture_check.h"
#include "calib/rig/rig_solver.h"
#include "image/capture_folder.h"
#include "service/api/service_context.h"
#include "service/jobs/calibration_request.h"
#include "service/jobs/compute_jobs.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

namespace fs = std::filesystem;

// A folder named by the client: relative, plain components, and inside the data folder
// once symbolic links are resolved.
Result<std::string> checked_folder(const ServiceContext& context, const std::string& folder) {
  if (folder.empty() || folder.size() > 256 || folder.front() == '/')
    return make_error(
        "invalid_request",
        "folder must be a relative path inside the data folder, e.g. captures/job-000012");
  for (char c : folder)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ||
          c == '/'))
      return make_error("invalid_request",
                        "folder may hold only letters, digits, '-', '_', '.' and '/'");
  for (const auto& part : fs::path(folder))
    if (part == ".." || part == ".")
      return make_error("invalid_request", "folder must not contain '.' or '..' components");
  std::error_code ec;
  const fs::path resolved = fs::weakly_canonical(context.data_dir / folder, ec);
  const std::string root = context.data_dir.string() + "/";
  if (ec || resolved.string().rfind(root, 0) != 0)
    return make_error("invalid_request", "folder '" + folder + "' is not inside the data folder");
  return fs::relative(resolved, context.data_dir).string();
}

// The capture folder a request names by "job" or "folder", checked to be readable.
Result<nlohmann::json> resolve_source(const ServiceContext& context, const nlohmann::json& body) {
  nlohmann::json source;
  if (body.contains("job") == body.contains("folder"))
    return make_error("invalid_request",
                      "give exactly one of \"job\" (a capture job id) or \"folder\" (a capture "
                      "folder under the data folder)");
  if (body.contains("job")) {
    if (!body["job"].is_number_integer() || body["job"].get<int64_t>() < 1)
      return make_error("invalid_request", "\"job\" must be a capture job id (a positive integer)");
    const int64_t id = body["job"].get<int64_t>();
    auto job = context.store->get(id);
    if (!job) return job.error();
    if (!job->has_value()) return make_error("not_found", "no job " + std::to_string(id));
    const JobRecord& j = **job;
    if (j.kind != "capture")
      return make_error("invalid_request",
                        "job " + std::to_string(id) + " is a " + j.kind + " job, not a capture");
    if (!is_finished(j.state))
      return make_error("conflict", "capture job " + std::to_string(id) + " is still " +
                                        job_state_name(j.state) + "; wait until it has finished");
    source = {{"source_job", id}, {"source_folder", j.folder}};
  } else {
    if (!body["folder"].is_string())
      return make_error("invalid_request", "\"folder\" must be a string");
    auto folder = checked_folder(context, body["folder"].get<std::string>());
    if (!folder) return folder.error();
    source = {{"source_folder", *folder}};
  }
  auto folder =
      image::CaptureFolder::open(context.data_dir / source["source_folder"].get<std::string>());
  if (!folder) return make_error("not_found", folder.error().message);
  if (folder->frames().empty())
    return make_error("no_frames", "the capture folder holds no frames");
  return source;
}

void queue_compute_job(const ServiceContext& context, const std::string& kind,
                       const nlohmann::json& request, const Reply& reply) {
  if (!context.compute->can_accept_job())
    return reply(error_response("too_many_jobs", "the compute queue is full; retry later"));
  // Each gets a folder for its outputs (the model, the plots).
  auto job = context.store->create(
      kind, "", request, kind == "calibration" ? "calibrations/job-" : "analyses/job-", 0);
  if (!job) return reply(error_response(job.error()));
  if (auto s = context.compute->enqueue_job(job->id); !s) {
    (void)context.store->finish(job->id, JobState::kCancelled, s.error(), nullptr);
    return reply(error_response(s.error()));
  }
  ApiResponse response = json_response(202, to_json(*job));
  response.headers.emplace_back("Location", "/v1/jobs/" + std::to_string(job->id));
  reply(std::move(response));
}

// A rig's sources: "rig": [{"job": N} or {"folder": "..."}, ...], one a camera, camera 0
// first (calib/rig/rig_calibrate.h; frames matched across cameras by file name).
Result<nlohmann::json> resolve_rig_sources(const ServiceContext& context,
                                           const nlohmann::json& rig) {
  if (!rig.is_array() || rig.size() < static_cast<size_t>(calib::kRigCamerasMin) ||
      rig.size() > static_cast<size_t>(calib::kRigCamerasMax))
    return make_error("invalid_request",
                      "\"rig\" must be an array of 2 to 8 sources, one a camera, camera 0 first: "
                      "[{\"job\": 12}, {\"job\": 13}] or [{\"folder\": \"imports/left\"}, ...]");
  nlohmann::json sources = nlohmann::json::array();
  for (size_t c = 0; c < rig.size(); ++c) {
    if (!rig[c].is_object())
      return make_error("invalid_request", "\"rig\"[" + std::to_string(c) + "] must be an object");
    if (Status known = check_known_fields(rig[c], {"job", "folder"}); !known)
      return known.error().with_context("\"rig\"[" + std::to_string(c) + "]: ");
    auto source = resolve_source(context, rig[c]);
    if (!source) return source.error().with_context("camera " + std::to_string(c) + ": ");
    sources.push_back(*source);
  }
  return sources;
}

// A rig capture's sources: "rig_capture": the id of a synchronised capture (sync_capture)
// whose cameras are the rig's, camera 0 first. Its rig views pair the frames (by start time,
// service/jobs/rig_views.h); only complete views within the capture's skew bound are
// calibrated, and how many were left out, and why, goes with the request.
Result<nlohmann::json> resolve_rig_capture(const ServiceContext& context,
                                           const nlohmann::json& id) {
  if (!id.is_number_integer() || id.get<int64_t>() < 1)
    return make_error("invalid_request",
                      "\"rig_capture\" must be a synchronised capture's job id (POST "
                      "/v1/sync-captures)");
  auto job = context.store->get(id.get<int64_t>());
  if (!job) return job.error();
  if (!job->has_value()) return make_error("not_found", "no job " + id.dump());
  const JobRecord& parent = **job;
  if (parent.kind != "sync_capture")
    return make_error("invalid_request", "job " + id.dump() + " is a " + parent.kind +
                                             " job, not a synchronised capture");
  if (parent.state != JobState::kSucceeded)
    return make_error("conflict", "synchronised capture " + id.dump() + " is " +
                                      job_state_name(parent.state) +
                                      "; a rig calibration needs one that succeeded");
  const nlohmann::json& cameras = parent.result.value("cameras", nlohmann::json::array());
  const nlohmann::json& views = parent.result.value("rig_views", nlohmann::json::object());
  if (cameras.size() < static_cast<size_t>(calib::kRigCamerasMin) ||
      cameras.size() > static_cast<size_t>(calib::kRigCamerasMax) || !views.contains("views"))
    return make_error("invalid_request",
                      "synchronised capture " + id.dump() + " has no rig views of 2 to 8 cameras");
  nlohmann::json sources = nlohmann::json::array(), frames = nlohmann::json::array();
  // Each camera's frame files by index, as its capture folder names them.
  std::vector<std::vector<std::string>> frame_files(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    auto source = resolve_source(context, {{"job", cameras[c].value("job", int64_t{0})}});
    if (!source) return source.error().with_context("camera " + std::to_string(c) + ": ");
    auto folder = image::CaptureFolder::open(context.data_dir /
                                             (*source)["source_folder"].get<std::string>());
    if (!folder) return folder.error().with_context("camera " + std::to_string(c) + ": ");
    for (const auto& entry : folder->frames())
      frame_files[c].push_back(fs::path(entry.image_file).filename().string());
    sources.push_back(*source);
    frames.push_back(nlohmann::json::object());
  }
  int taken = 0, incomplete = 0, over_bound = 0;
  for (const nlohmann::json& view : views["views"]) {
    if (!view.value("complete", false)) {
      ++incomplete;
      continue;
    }
    if (!view.value("within_bound", false)) {
      ++over_bound;
      continue;
    }
    bool stored = true;  // every camera's frame of the view is in its folder
    for (size_t c = 0; c < cameras.size(); ++c) {
      const int index = view["frames"][c].get<int>();
      stored = stored && index >= 0 && index < static_cast<int>(frame_files[c].size());
    }
    if (!stored) {
      ++incomplete;
      continue;
    }
    char name[32];
    std::snprintf(name, sizeof name, "view_%04d", taken++);
    for (size_t c = 0; c < cameras.size(); ++c)
      frames[c][frame_files[c][static_cast<size_t>(view["frames"][c].get<int>())]] = name;
  }
  if (taken < 3)
    return make_error("too_few_views",
                      "synchronised capture " + id.dump() + " has " + std::to_string(taken) +
                          " complete rig views within its skew bound (" +
                          std::to_string(incomplete) + " incomplete, " +
                          std::to_string(over_bound) + " over the bound); a rig needs 3");
  return nlohmann::json{
      {"rig_sources", sources},
      {"rig_view_frames", frames},
      {"rig_views_left_out", {{"incomplete", incomplete}, {"over_bound", over_bound}}}};
}

void post_calibration(const ServiceContext& context, const ApiRequest& request, Reply reply) {
  auto body = parse_json_object(request.body);
  if (!body) return reply(error_response(body.error()));
  if (Status known = check_known_fields(
          *body, {"job", "folder", "rig", "rig_capture", "inner_corners", "spacing_m", "detector",
                  "marker_m", "dictionary", "model", "pixel_um"});
      !known)
    return reply(error_response(known.error()));
  auto normalised = normalised_calibration_fields(*body);
  if (!normalised) return reply(error_response(normalised.error()));
  // The source last: a malformed request is refused before any file is looked at.
  if (body->contains("rig_capture")) {
    if (body->contains("rig") || body->contains("job") || body->contains("folder"))
      return reply(error_response("invalid_request",
                                  "give \"rig_capture\" alone, not with \"rig\", \"job\" or "
                                  "\"folder\""));
    auto resolved = resolve_rig_capture(context, (*body)["rig_capture"]);
    if (!resolved) return reply(error_response(resolved.error()));
    for (const auto& [key, value] : resolved->items()) (*normalised)[key] = value;
    (*normalised)["rig_capture"] = (*body)["rig_capture"];
    return queue_compute_job(context, "calibration", *normalised, reply);
  }
  if (body->contains("rig")) {
    if (body->contains("job") || body->contains("folder"))
      return reply(error_response("invalid_request",
                                  "give \"rig\" (one source a camera) or one \"job\" or "
                                  "\"folder\", not both"));
    auto sources = resolve_rig_sources(context, (*body)["rig"]);
    if (!sources) return reply(error_response(sources.error()));
    (*normalised)["rig_sources"] = *sources;
    return queue_compute_job(context, "calibration", *normalised, reply);
  }
  auto source = resolve_source(context, *body);
  if (!source) return reply(error_response(source.error()));
  for (const auto& [key, value] : source->items()) (*normalised)[key] = value;
  queue_compute_job(context, "calibration", *normalised, reply);
}

void post_analysis(const ServiceContext& context, const ApiRequest& request, Reply reply) {
  auto body = parse_json_object(request.body);
  if (!body) return reply(error_response(body.error()));
  if (Status known = check_known_fields(*body, {"kind", "job", "folder"}); !known)
    return reply(error_response(known.error()));
  const nlohmann::json& kind = body->value("kind", nlohmann::json());
  if (!kind.is_string() || (kind != "defocus" && kind != "exposure" && kind != "focus" &&
                            kind != "sfr" && kind != "lensmap"))
    return reply(error_response("invalid_request",
                                "\"kind\" must be \"defocus\", \"exposure\", \"focus\", "
                                "\"sfr\" or \"lensmap\""));
  auto source = resolve_source(context, *body);
  if (!source) return reply(error_response(source.error()));
  // The wrong capture for the analysis is refused now (422), not run into an empty report.
  auto folder =
      image::CaptureFolder::open(context.data_dir / (*source)["source_folder"].get<std::string>());
  if (!folder) return reply(error_response(folder.error()));
  if (Status fits = analysis::check_capture_for(kind.get<std::string>(), *folder); !fits)
    return reply(error_response(fits.error()));
  nlohmann::json normalised = *source;
  normalised["analysis"] = kind;
  queue_compute_job(context, "analysis", normalised, reply);
}

}  // namespace

void add_compute_routes(Router& router, const ServiceContext& context) {
  router.add({"POST", "/v1/calibrations",
              "Queue a calibration (mrcal) of a capture's chessboard frames: 202 with the job; the "
              "result holds "
              "the report and the .cameramodel",
              [context](const ApiRequest& request, const PathParams&, Reply reply) {
                post_calibration(context, request, std::move(reply));
              }});
  router.add(
      {"POST", "/v1/analyses",
       "Queue an analysis (defocus, exposure, focus, sfr, lensmap) of a capture: 202 with the job; "
       "the result holds the report",
       [context](const ApiRequest& request, const PathParams&, Reply reply) {
         post_analysis(context, request, std::move(reply));
       }});
}

}  // namespace camlab::service
