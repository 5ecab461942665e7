// The OpenAPI 3.0 document of camlabd's API (GET /v1/openapi.json). Written by hand, so
// it documents bodies and errors; tests/integration/service checks that its paths and
// methods are exactly the router's.
#include "calib/calibration_request.h"
#include "capture/capture_plan.h"
#include "service/api/service_context.h"

namespace camlab::service {

namespace {

using nlohmann::json;

json ref(const std::string& name) { return {{"$ref", "#/components/schemas/" + name}}; }

json error_responses(std::initializer_list<int> statuses) {
  static const std::map<int, std::string> kText = {
      {400, "Malformed request (bad JSON, missing or mistyped fields, bad path parameter)"},
      {401, "Missing or wrong bearer token"},
      {404, "No such camera, job or frame"},
      {409, "Conflict (camera busy, job already finished, source job still running)"},
      {413, "Body too large"},
      {422, "A value outside the camera's range (the message names it) or unsupported"},
      {429, "Too many jobs queued"},
      {503, "Camera unavailable or daemon shutting down"}};
  json out = json::object();
  for (int s : statuses)
    out[std::to_string(s)] = {{"description", kText.at(s)},
                              {"content", {{"application/json", {{"schema", ref("Error")}}}}}};
  return out;
}

// The limits calib/calibration_request.h checks, as the document states them.
json inner_corners_schema() {
  return {{"type", "array"},
          {"items",
           {{"type", "integer"},
            {"minimum", calib::kBoardInnerCornersMin},
            {"maximum", calib::kBoardInnerCornersMax}}},
          {"minItems", 2},
          {"maxItems", 2}};
}
json spacing_schema() {
  return {{"type", "number"},
          {"minimum", calib::kBoardSpacingMinM},
          {"maximum", calib::kBoardSpacingMaxM},
          {"description", "corner spacing (m)"}};
}
json pixel_schema() {
  return {{"type", "number"},
          {"minimum", calib::kPixelPitchMinUm},
          {"maximum", calib::kPixelPitchMaxUm},
          {"description", "pixel pitch (um)"}};
}

json operation(const std::string& summary, const std::string& tag, json parameters, json responses,
               json request_schema = nullptr) {
  // Any request may meet these, whatever its route: every connection busy, a fleet host's
  // database out of reach, a stop under way (503); the database or a camera past its
  // time (504).
  if (!responses.contains("503"))
    responses["503"] = {{"description",
                         "Every connection busy (too_many_connections), the fleet's database out "
                         "of reach, or shutting down; Retry-After says when to try again"},
                        {"content", {{"application/json", {{"schema", ref("Error")}}}}}};
  if (!responses.contains("504"))
    responses["504"] = {{"description", "The database or the camera did not answer in time"},
                        {"content", {{"application/json", {{"schema", ref("Error")}}}}}};
  json op = {{"summary", summary}, {"tags", {tag}}, {"responses", std::move(responses)}};
  if (!parameters.empty()) op["parameters"] = std::move(parameters);
  if (!request_schema.is_null())
    op["requestBody"] = {{"required", true},
                         {"content", {{"application/json", {{"schema", request_schema}}}}}};
  return op;
}

json path_param(const std::string& name, const std::string& description, json schema) {
  return {{"name", name},
          {"in", "path"},
          {"required", true},
          {"description", description},
          {"schema", schema}};
}

json ok(int status, const std::string& description, json schema,
        const std::string& type = "application/json") {
  return {{std::to_string(status),
           {{"description", description}, {"content", {{type, {{"schema", schema}}}}}}}};
}

json merge(json a, const json& b) {
  for (const auto& [k, v] : b.items()) a[k] = v;
  return a;
}

json schemas() {
  return {
      {"Error",
       {{"type", "object"},
        {"required", {"error"}},
        {"properties",
         {{"error",
           {{"type", "object"},
            {"required", {"code", "message"}},
            {"properties",
             {{"code", {{"type", "string"}}}, {"message", {{"type", "string"}}}}}}}}}}},
      {"Job",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"kind",
           {{"type", "string"},
            {"enum", {"capture", "latency_probe", "calibration", "analysis", "sync_capture"}}}},
          {"state",
           {{"type", "string"},
            {"enum",
             {"queued", "running", "succeeded", "failed", "cancelled", "interrupted",
              "device_lost"}}}},
          {"camera_id", {{"type", "string"}}},
          {"host",
           {{"type", "string"},
            {"description", "fleet only: the host that runs the job and keeps its frames"}}},
          {"request", {{"type", "object"}}},
          {"folder", {{"type", "string"}, {"description", "relative to the data folder"}}},
          {"created_at", {{"type", "string"}, {"format", "date-time"}}},
          {"started_at", {{"type", "string"}, {"format", "date-time"}, {"nullable", true}}},
          {"finished_at", {{"type", "string"}, {"format", "date-time"}, {"nullable", true}}},
          {"progress",
           {{"type", "object"},
            {"properties",
             {{"frames_done", {{"type", "integer"}}},
              {"frames_total", {{"type", "integer"}}},
              {"frames_discarded", {{"type", "integer"}}},
              {"fraction", {{"type", "number"}}}}}}},
          {"error", ref("Error")},
          {"result", {{"type", "object"}, {"nullable", true}}}}}}},
      {"CaptureRequest",
       {{"type", "object"},
        {"required", {"kind"}},
        {"description",
         "single: {}; bracket: exposures_us[] (+ gain) or base_exposure_us + ev_steps[]; "
         "focus_stack: positions[] "
         "or start/stop/step; aperture_series: f_numbers[] or iris_positions[] (+ "
         "base_exposure_us); lens_map: an "
         "aperture series' fields and a focus stack's (every stop x every position, the focus "
         "stepped inside each stop; base_exposure_us: the first stop's time, the others' "
         "grown as N^2 so that every stop is exposed alike). Common: repeats, "
         "format "
         "{fourcc, width, height}, controls {name: value}."},
        {"properties",
         {{"kind",
           {{"type", "string"},
            {"enum", {"single", "bracket", "focus_stack", "aperture_series", "lens_map"}}}},
          {"exposures_us", {{"type", "array"}, {"items", {{"type", "number"}}}}},
          {"base_exposure_us", {{"type", "number"}}},
          {"ev_steps", {{"type", "array"}, {"items", {{"type", "number"}}}}},
          {"gain", {{"type", "number"}}},
          {"positions", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
          {"start", {{"type", "integer"}}},
          {"stop", {{"type", "integer"}}},
          {"step", {{"type", "integer"}}},
          {"f_numbers", {{"type", "array"}, {"items", {{"type", "number"}}}}},
          {"iris_positions", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
          {"repeats", {{"type", "integer"}, {"minimum", 1}, {"maximum", capture::kMaxRepeats}}},
          {"exposure_us",
           {{"type", "number"},
            {"description", "exposure held through a focus stack, aperture series or single"}}},
          {"label", {{"type", "string"}, {"description", "free text kept with the job"}}},
          {"format",
           {{"type", "object"},
            {"properties",
             {{"fourcc", {{"type", "string"}, {"maxLength", 4}}},
              {"width", {{"type", "integer"}}},
              {"height", {{"type", "integer"}}},
              {"frame_interval_us", {{"type", "number"}}}}},
            {"additionalProperties", false}}},
          {"controls", {{"type", "object"}, {"additionalProperties", {{"type", "integer"}}}}}}}}},
      {"Controls",
       {{"type", "object"},
        {"description", "control name (V4L2 style) -> value in the control's own unit"},
        {"additionalProperties", {{"type", "integer"}}}}},
      {"CalibrationRequest",
       {{"type", "object"},
        {"required", {"inner_corners", "spacing_m"}},
        {"properties",
         {{"job", {{"type", "integer"}, {"description", "a finished capture job"}}},
          {"folder",
           {{"type", "string"}, {"description", "or a capture folder under the data folder"}}},
          {"rig",
           {{"type", "array"},
            {"minItems", 2},
            {"maxItems", 8},
            {"items",
             {{"type", "object"},
              {"properties", {{"job", {{"type", "integer"}}}, {"folder", {{"type", "string"}}}}},
              {"additionalProperties", false}}},
            {"description",
             "or a rig: one capture (job or folder) a camera, camera 0 first, frames matched "
             "by file name; the result's report is rig.json (each camera's pose relative to "
             "camera 0 with its 1-sigma, rectification, epipolar residual) and the job's "
             "folder holds camera-N.cameramodel"}}},
          {"inner_corners", inner_corners_schema()},
          {"spacing_m", spacing_schema()},
          {"model",
           {{"type", "string"},
            {"maxLength", 200},
            {"description",
             "auto (default) or a mrcal LENSMODEL_... name; a splined model within order 2-3, "
             "4-40 knots each way and 900 in all, fov_x_deg 10-300 (else 422 out_of_range)"}}},
          {"detector",
           {{"type", "string"},
            {"enum", {"auto", "saddle", "opencv", "mrgingham", "markers", "charuco"}},
            {"description",
             "auto (default): camlab's saddle-point detector, with mrgingham on square boards "
             "where it misses; markers: a chessboard with OpenCV's circle markers (cut boards "
             "kept); "
             "charuco: a ChArUco board (give marker_m and dictionary)"}}},
          {"marker_m",
           {{"type", "number"},
            {"description", "ChArUco: a marker's side (m), its black border included"}}},
          {"dictionary",
           {{"type", "string"}, {"description", "ChArUco: OpenCV's dictionary, e.g. DICT_4X4_50"}}},
          {"pixel_um", pixel_schema()}}},
        {"additionalProperties", false}}},
      {"CalibrationSessionRequest",
       {{"type", "object"},
        {"required", {"camera", "inner_corners", "spacing_m"}},
        {"properties",
         {{"camera", {{"type", "string"}, {"description", "a camera id (GET /v1/cameras)"}}},
          {"inner_corners", inner_corners_schema()},
          {"spacing_m", spacing_schema()},
          {"model",
           {{"type", "string"},
            {"description",
             "auto (default: OPENCV8 during the loop, selection at the finish) or a mrcal "
             "LENSMODEL_... name"}}},
          {"detector",
           {{"type", "string"}, {"enum", {"auto", "saddle", "opencv", "mrgingham", "charuco"}}}},
          {"marker_m", {{"type", "number"}}},
          {"dictionary", {{"type", "string"}}},
          {"pixel_um", pixel_schema()},
          {"target_uncertainty_px",
           {{"type", "number"},
            {"minimum", 0.01},
            {"maximum", 100},
            {"default", 0.5},
            {"description",
             "worst projection uncertainty over the imager (px, at the working distance) at "
             "which the session has enough views"}}}}},
        {"additionalProperties", false}}},
      {"AnalysisRequest",
       {{"type", "object"},
        {"required", {"kind"}},
        {"properties",
         {{"kind",
           {{"type", "string"}, {"enum", {"defocus", "exposure", "focus", "sfr", "lensmap"}}}},
          {"job", {{"type", "integer"}, {"minimum", 1}}},
          {"folder", {{"type", "string"}}}}},
        {"additionalProperties", false}}},
      {"CameraSummary",
       {{"type", "object"},
        {"properties",
         {{"id",
           {{"type", "string"},
            {"description", "v4l2:BUS_INFO or libcamera:ID; kept across replugs"}}},
          {"backend", {{"type", "string"}, {"enum", {"v4l2", "libcamera"}}}},
          {"name", {{"type", "string"}}},
          {"path", {{"type", "string"}}},
          {"transport", {{"type", "string"}}},
          {"available", {{"type", "boolean"}}},
          {"unavailable_reason", {{"type", "string"}}},
          {"present",
           {{"type", "boolean"}, {"description", "false while an unplugged camera is gone"}}},
          {"gone_since_ms", {{"type", "integer"}, {"description", "Unix time in ms"}}},
          {"also_reachable_as",
           {{"type", "string"}, {"description", "the same camera's id under the other backend"}}},
          {"running_job", {{"type", "integer"}, {"nullable", true}}},
          {"queued_jobs", {{"type", "integer"}}},
          {"control_latency", {{"type", "object"}, {"nullable", true}}}}}}},
      {"SyncCaptureRequest",
       {{"type", "object"},
        {"required", {"cameras", "capture"}},
        {"properties",
         {{"cameras",
           {{"type", "array"},
            {"items", {{"type", "string"}, {"description", "CAMERA@HOST (GET /v1/fleet)"}}},
            {"minItems", 1},
            {"maxItems", 32}}},
          {"capture", ref("CaptureRequest")},
          {"start_in_ms",
           {{"type", "integer"},
            {"minimum", 100},
            {"maximum", 60000},
            {"default", 1000},
            {"description", "the common start, this long after the request (host clocks)"}}},
          {"max_late_ms",
           {{"type", "integer"},
            {"minimum", 0},
            {"maximum", 10000},
            {"default", 100},
            {"description", "a camera that can begin only later than this fails busy"}}},
          {"max_skew_us",
           {{"type", "integer"},
            {"minimum", 0},
            {"maximum", 1000000},
            {"default", 1000},
            {"description", "a rig view whose frames start further apart is flagged"}}}}}}},
      {"Faults",
       {{"type", "object"},
        {"properties",
         {{"unplug", {{"type", "boolean"}}},
          {"replug", {{"type", "boolean"}}},
          {"fail_next_dequeues", {{"type", "integer"}}},
          {"drop_next_frames", {{"type", "integer"}}},
          {"stall", {{"type", "boolean"}}}}}}}};
}

// The dashboard's page and files, and what it reads: the live view, the histogram, frame
// thumbnails, plots and job events (docs/dashboard.md).
void add_dashboard_paths(json& paths, const json& camera_id, const json& job_id,
                         const json& frame_n) {
  const json object = {{"type", "object"}};
  const json binary = {{"type", "string"}, {"format", "binary"}};
  auto query = [](const std::string& name, const std::string& description, json schema) {
    return json{{"name", name}, {"in", "query"}, {"description", description}, {"schema", schema}};
  };
  auto number = [](double min, double max, double fallback) {
    return json{{"type", "number"}, {"minimum", min}, {"maximum", max}, {"default", fallback}};
  };
  const json flag = {{"type", "integer"}, {"enum", {0, 1}}, {"default", 0}};
  const json display = {
      query("width", "width shown, px (scaled down, never up)", number(16, 4096, 640)),
      query("peaking", "focus peaking overlay (green)", flag),
      query("peaking_threshold", "Sobel gradient on 0-255 display values", number(1, 1000, 150)),
      query("clipping", "clipping overlay: red at the white level, blue at the black level", flag),
      query("quality", "JPEG quality", number(10, 100, 80))};
  json live_parameters = {camera_id, query("fps", "frame-rate cap, frames/s", number(0.2, 30, 10))};
  for (const auto& p : display) live_parameters.push_back(p);
  json frame_parameters = {camera_id};
  for (const auto& p : display) frame_parameters.push_back(p);
  const json public_operation = {{"security", json::array()}};
  paths["/"] = {
      {"get", merge(operation("The dashboard (no token: the page asks for it)", "dashboard",
                              json::array(), ok(200, "HTML", {{"type", "string"}}, "text/html")),
                    public_operation)}};
  paths["/ui/{name}"] = {
      {"get",
       merge(operation("The dashboard's scripts, style and icon", "dashboard",
                       {path_param("name", "file name", {{"type", "string"}})},
                       merge(ok(200, "the file", {{"type", "string"}}), error_responses({404}))),
             public_operation)}};
  paths["/v1/cameras/{id}/live"] = {
      {"get", operation("Live view: multipart/x-mixed-replace of JPEG frames (each part has "
                        "Content-Length, X-Frame-Sequence, X-Frame-Timestamp-Ns, X-Frame-Width, "
                        "X-Frame-Height, X-Frame-Repeated), at most fps a second; runs beside "
                        "captures without changing which frames they keep",
                        "live", live_parameters,
                        merge(ok(200, "the stream, until the client or the camera goes", binary,
                                 "multipart/x-mixed-replace"),
                              error_responses({400, 401, 404, 503})))}};
  paths["/v1/cameras/{id}/live/frame"] = {
      {"get", operation("The camera's next frame as one JPEG", "live", frame_parameters,
                        merge(ok(200, "JPEG", binary, "image/jpeg"),
                              error_responses({400, 401, 404, 503})))}};
  paths["/v1/cameras/{id}/histogram"] = {
      {"get",
       operation("Histogram of the next frame's raw DN per channel (Y; R, Gr, Gb, B for a "
                 "Bayer mosaic; R, G, B), with the black and white levels, mean, range "
                 "and the shares clipped",
                 "live",
                 {camera_id, query("bins", "bins over [0, 2^bit_depth)", number(1, 4096, 256))},
                 merge(ok(200, "histogram", object), error_responses({400, 401, 404, 503})))}};
  paths["/v1/jobs/{id}/frames/{n}/thumbnail"] = {
      {"get", operation("Frame n shown small (JPEG)", "jobs",
                        {job_id, frame_n, query("width", "px", number(16, 4096, 160)),
                         query("clipping", "clipping overlay", flag)},
                        merge(ok(200, "JPEG", binary, "image/jpeg"),
                              error_responses({400, 401, 404, 422})))}};
  const json pixels = {{"type", "integer"}, {"minimum", 0}};
  paths["/v1/jobs/{id}/frames/{n}/region"] = {
      {"get",
       operation("Raw DN of a rectangle of frame n: per channel (Y; R, Gr, Gb, B; R, G, B) "
                 "mean, sd, SNR = (mean - black) / sd, min and max; every sample of a region "
                 "of at most 64",
                 "jobs",
                 {job_id, frame_n, query("x", "left column, px", pixels),
                  query("y", "top row, px", pixels),
                  query("width", "px (1)", {{"type", "integer"}, {"minimum", 1}}),
                  query("height", "px (1)", {{"type", "integer"}, {"minimum", 1}})},
                 merge(ok(200, "region statistics", object),
                       error_responses({400, 401, 404, 422, 503})))}};
  paths["/v1/jobs/{id}/plots"] = {
      {"get",
       operation("The plots an analysis or calibration job drew", "jobs", {job_id},
                 merge(ok(200, "{plots: [{name, image, data}]}: data, the chart as JSON", object),
                       error_responses({400, 401, 404})))}};
  paths["/v1/jobs/{id}/plots/{name}"] = {
      {"get",
       operation("One plot (PNG)", "jobs",
                 {job_id, path_param("name", "e.g. linearity.png", {{"type", "string"}})},
                 merge(ok(200, "PNG", binary, "image/png"), error_responses({400, 401, 404})))}};
  paths["/v1/jobs/{id}/files"] = {
      {"get", operation("Every file the job wrote: frames, sidecars, manifest, model, report, "
                        "plots",
                        "jobs", {job_id},
                        merge(ok(200, "{job_id, folder, files: [{path, bytes, url}]}", object),
                              error_responses({400, 401, 404})))}};
  const json file_name = path_param("name", "e.g. report.json", {{"type", "string"}});
  paths["/v1/jobs/{id}/files/{name}"] = {
      {"get", operation("One file of the job, byte for byte", "jobs", {job_id, file_name},
                        merge(ok(200, "the file", binary, "application/octet-stream"),
                              error_responses({400, 401, 404})))}};
  paths["/v1/jobs/{id}/files/{dir}/{name}"] = {
      {"get", operation("One file in a subfolder of the job's (plots), byte for byte", "jobs",
                        {job_id, path_param("dir", "e.g. plots", {{"type", "string"}}), file_name},
                        merge(ok(200, "the file", binary, "application/octet-stream"),
                              error_responses({400, 401, 404})))}};
  paths["/v1/events"] = {
      {"get",
       operation("Job changes as server-sent events: event \"job\" with data {id, state, "
                 "frames_done, frames_total, frames_discarded}; \"resync\" when the client "
                 "fell behind; a comment every 15 s",
                 "jobs", json::array(),
                 merge(ok(200, "the event stream", {{"type", "string"}}, "text/event-stream"),
                       error_responses({401, 503})))}};
}

}  // namespace

json openapi_document(bool include_test_routes) {
  const json camera_id = path_param(
      "id", "camera id as listed by GET /v1/cameras (percent-encoded)", {{"type", "string"}});
  const json job_id = path_param("id", "job id", {{"type", "integer"}, {"minimum", 1}});
  const json frame_n =
      path_param("n", "frame index, 0-based", {{"type", "integer"}, {"minimum", 0}});
  const json object = {{"type", "object"}};
  json paths = {
      {"/v1/health",
       {{"get", merge(operation("Liveness (no token needed)", "system", json::array(),
                                ok(200, "serving", object)),
                      {{"security", json::array()}})}}},
      {"/metrics",
       {{"get", operation("Prometheus metrics", "system", json::array(),
                          merge(ok(200, "text format 0.0.4", {{"type", "string"}}, "text/plain"),
                                error_responses({401})))}}},
      {"/v1/openapi.json",
       {{"get", operation("This document", "system", json::array(),
                          merge(ok(200, "OpenAPI 3", object), error_responses({401})))}}},
      {"/v1/cameras",
       {{"get",
         operation("Cameras", "cameras", json::array(),
                   merge(ok(200, "every camera, gone ones included",
                            {{"type", "object"},
                             {"properties",
                              {{"cameras",
                                {{"type", "array"},
                                 {"items", {{"$ref", "#/components/schemas/CameraSummary"}}}}}}}}),
                         error_responses({401})))}}},
      {"/v1/cameras/{id}",
       {{"get",
         operation("A camera: formats, controls with ranges and units, control latency", "cameras",
                   {camera_id}, merge(ok(200, "camera", object), error_responses({401, 404})))}}},
      {"/v1/cameras/{id}/controls",
       {{"put", operation("Set controls", "cameras", {camera_id},
                          merge(ok(200, "{controls: {name: {requested, applied}}}", object),
                                error_responses({400, 401, 404, 409, 413, 422, 503})),
                          ref("Controls"))}}},
      {"/v1/cameras/{id}/captures",
       {{"post", operation("Queue a capture", "captures", {camera_id},
                           merge(ok(202, "the queued job (Location: /v1/jobs/{id})", ref("Job")),
                                 error_responses({400, 401, 404, 413, 422, 429, 503})),
                           ref("CaptureRequest"))}}},
      {"/v1/cameras/{id}/latency-probe",
       {{"post", operation("Queue a control-latency probe; the result is stored for the camera",
                           "captures", {camera_id},
                           merge(ok(202, "the queued job", ref("Job")),
                                 error_responses({401, 404, 429})))}}},
      {"/v1/jobs",
       {{"get",
         operation("Jobs, newest first", "jobs",
                   {{{"name", "state"}, {"in", "query"}, {"schema", {{"type", "string"}}}},
                    {{"name", "limit"},
                     {"in", "query"},
                     {"schema", {{"type", "integer"}, {"maximum", 1000}}}},
                    {{"name", "offset"}, {"in", "query"}, {"schema", {{"type", "integer"}}}}},
                   merge(ok(200, "{jobs: [...]}", object), error_responses({400, 401})))}}},
      {"/v1/jobs/{id}",
       {{"get", operation("A job; with ?wait=S the answer comes once it has finished or after S "
                          "seconds, whichever is first",
                          "jobs",
                          {job_id,
                           {{"name", "wait"},
                            {"in", "query"},
                            {"description", "seconds to wait for the job to finish (long-poll)"},
                            {"schema", {{"type", "number"}, {"minimum", 0}, {"maximum", 60}}}}},
                          merge(ok(200, "the job", ref("Job")), error_responses({400, 401, 404})))},
        {"delete",
         operation(
             "Cancel a job (200 when queued, 202 when running: stops between frames, frames kept)",
             "jobs", {job_id},
             merge(merge(ok(200, "cancelled", ref("Job")), ok(202, "cancel requested", ref("Job"))),
                   error_responses({400, 401, 404, 409})))}}},
      {"/v1/jobs/{id}/frames",
       {{"get", operation("Frames written so far", "jobs", {job_id},
                          merge(ok(200, "{frames: [{index, image, meta}], complete}", object),
                                error_responses({400, 401, 404, 422})))}}},
      {"/v1/jobs/{id}/frames/{n}",
       {{"get",
         operation("Frame n as PNG", "jobs", {job_id, frame_n},
                   merge(ok(200, "PNG", {{"type", "string"}, {"format", "binary"}}, "image/png"),
                         error_responses({400, 401, 404, 422})))}}},
      {"/v1/jobs/{id}/frames/{n}/meta",
       {{"get", operation("Frame n's sidecar", "jobs", {job_id, frame_n},
                          merge(ok(200, "sidecar (docs/capture-folder.md)", object),
                                error_responses({400, 401, 404, 422})))}}},
      {"/v1/calibrations",
       {{"post", operation("Queue a calibration", "compute", json::array(),
                           merge(ok(202, "the queued job; its result holds report and cameramodel",
                                    ref("Job")),
                                 error_responses({400, 401, 404, 409, 413, 422, 429})),
                           ref("CalibrationRequest"))}}},
      {"/v1/analyses",
       {{"post", operation("Queue an analysis", "compute", json::array(),
                           merge(ok(202, "the queued job; its result holds the report", ref("Job")),
                                 error_responses({400, 401, 404, 409, 413, 422, 429})),
                           ref("AnalysisRequest"))}}}};
  add_dashboard_paths(paths, camera_id, job_id, frame_n);
  // The fleet (docs/fleet.md): on one camlabd (SQLite) both answer unsupported (422).
  paths["/v1/fleet"] = {
      {"get", operation("The fleet: hosts with their leases, clock offsets and cameras "
                        "(CAMERA@HOST)",
                        "fleet", json::array(),
                        merge(ok(200, "{host, hosts: [{name, url, state, cameras}]}", object),
                              error_responses({401, 422, 503})))}};
  paths["/v1/sync-captures"] = {
      {"post", operation("A synchronised capture: cameras (on several hosts of a fleet, or this "
                         "camlabd's own) start at a common time",
                         "fleet", json::array(),
                         merge(ok(202,
                                  "the parent job (kind sync_capture); its result compares the "
                                  "frames' start times",
                                  ref("Job")),
                               error_responses({400, 401, 404, 413, 422, 429, 503})),
                         ref("SyncCaptureRequest"))}};
  // A job's files stay on the host that ran it: another fleet host redirects there.
  for (const char* files :
       {"/v1/jobs/{id}/frames", "/v1/jobs/{id}/frames/{n}", "/v1/jobs/{id}/frames/{n}/meta",
        "/v1/jobs/{id}/frames/{n}/thumbnail", "/v1/jobs/{id}/frames/{n}/region",
        "/v1/jobs/{id}/plots", "/v1/jobs/{id}/plots/{name}", "/v1/jobs/{id}/files",
        "/v1/jobs/{id}/files/{name}", "/v1/jobs/{id}/files/{dir}/{name}"})
    paths[files]["get"]["responses"]["307"] = {
        {"description", "fleet: the job's files are on another host (Location, same token)"}};
  const json session_id =
      path_param("id", "calibration session id", {{"type", "integer"}, {"minimum", 1}});
  const std::string session_state =
      "the session: phase (ready, capturing, solving, finishing, ended), frames, solution, "
      "uncertainty over the imager, suggestion of the next view, last_error";
  paths["/v1/calibration-sessions"] = {
      {"post", operation("Open a guided calibration on a camera", "calibration", json::array(),
                         merge(ok(201, session_state, object),
                               error_responses({400, 401, 404, 413, 422, 429, 503})),
                         ref("CalibrationSessionRequest"))}};
  paths["/v1/calibration-sessions/{id}"] = {
      {"get", operation("A calibration session's state", "calibration", {session_id},
                        merge(ok(200, session_state, object), error_responses({400, 401, 404})))},
      {"delete",
       operation("Cancel a calibration session", "calibration", {session_id},
                 merge(ok(200, session_state, object), error_responses({400, 401, 404, 409})))}};
  paths["/v1/calibration-sessions/{id}/views"] = {
      {"post", operation("Take a view: capture, detect, solve, suggest the next (poll the "
                         "session until its phase is ready)",
                         "calibration", {session_id},
                         merge(ok(202, session_state, object),
                               error_responses({400, 401, 404, 409, 429, 503})))}};
  paths["/v1/calibration-sessions/{id}/finish"] = {
      {"post", operation("Calibrate on every view of the session into a .cameramodel and a "
                         "report (poll the session until its phase is ended)",
                         "calibration", {session_id},
                         merge(ok(202, session_state, object),
                               error_responses({400, 401, 404, 409, 422})))}};
  if (include_test_routes)
    paths["/v1/test/cameras/{id}/faults"] = {
        {"post",
         merge(
             operation("TEST ONLY: inject faults into an in-process virtual camera (--test-faults)",
                       "test", {camera_id},
                       merge(ok(200, "injected", object), error_responses({400, 401, 404, 422})),
                       ref("Faults")),
             {{"x-test-only", true}})}};
  if (include_test_routes)
    paths["/v1/test/cameras/{id}/scene"] = {
        {"post",
         merge(operation("TEST ONLY: move a target of an in-process virtual camera's scene "
                         "(--test-faults): {\"target\": NAME, \"pose\": rt_cam_target}",
                         "test", {camera_id},
                         merge(ok(200, "moved", object), error_responses({400, 401, 404, 422})),
                         object),
               {{"x-test-only", true}})}};
  return {{"openapi", "3.0.3"},
          {"info",
           {{"title", "camlabd"},
            {"version", "0.1.0"},
            {"description",
             "REST capture of exposure brackets, focus stacks and aperture series with "
             "frame-accurate settings. "
             "Every endpoint but GET /v1/health and the dashboard's page and files needs "
             "'Authorization: Bearer TOKEN' (DATA/token). "
             "Errors are "
             "{\"error\": {\"code\", \"message\"}}."}}},
          {"servers", {{{"url", "http://127.0.0.1:8080"}}}},
          {"security", {{{"bearer", json::array()}}}},
          {"components",
           {{"securitySchemes", {{"bearer", {{"type", "http"}, {"scheme", "bearer"}}}}},
            {"schemas", schemas()}}},
          {"paths", paths}};
}

}  // namespace camlab::service
