// The fleet (docs/fleet.md): GET /v1/fleet, POST /v1/sync-captures, and, on a fleet host,
// the camera and job routes answered for the whole fleet. Wrapped around one camlabd's
// handlers (Router::wrap), they pass on what concerns this host alone:
//
// - POST /v1/cameras/{id}/captures and /latency-probe: the camera may be another host's
//   ("CAMERA@HOST"); the request is checked against the camera as its host published it,
//   and the job waits in the database for that host to claim it (this host's own cameras
//   too, so that a job survives its host's death until the lease passes).
// - GET /v1/cameras/{id} of another host's camera: as that host published it.
// - DELETE /v1/jobs/{id} of a job running on another host: a cancel request that host
//   acts on; of a synchronised capture: every one of its captures.
// - GET /v1/jobs/{id}/frames... and /plots...: a job's files stay on the host that ran it;
//   a request for another host's is redirected there (307, the same token: hosts of a
//   fleet share one). So are the live view, histogram and controls of another host's camera.
#include <string>

#include "service/api/api_lookup.h"
#include "service/api/service_context.h"
#include "service/fleet/fleet.h"
#include "service/fleet/sync_captures.h"
#include "service/jobs/camera_set.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

Error not_in_a_fleet() {
  return make_error("unsupported",
                    "this camlabd keeps its jobs in SQLite and is in no fleet; start it with "
                    "--db postgresql://... (docs/fleet.md)");
}

ApiResponse accepted_job(const JobRecord& job) {
  ApiResponse response = json_response(202, to_json(job));
  response.headers.emplace_back("Location", "/v1/jobs/" + std::to_string(job.id));
  return response;
}

nlohmann::json fleet_json(Fleet& fleet) {
  nlohmann::json hosts = nlohmann::json::array();
  for (const FleetHost& host : fleet.registry().hosts()) {
    nlohmann::json cameras = nlohmann::json::array();
    for (const FleetCamera& camera : host.cameras)
      cameras.push_back({{"id", fleet_camera_id(camera.camera_id, host.name)},
                         {"camera_id", camera.camera_id},
                         {"name", camera.description.value("name", "")},
                         {"available", camera.available},
                         {"running_job", camera.running_job ? nlohmann::json(camera.running_job)
                                                            : nlohmann::json(nullptr)},
                         {"queued_jobs", camera.queued_jobs}});
    hosts.push_back({{"name", host.name},
                     {"url", host.url},
                     {"state", host.starting() ? std::string("starting") : host.state},
                     {"started_ms", host.started_ms},
                     {"lease_ms", host.lease_ms},
                     {"lease_remaining_ms", host.lease_remaining_ms},
                     {"renewed_ago_ms", host.renewed_ago_ms},
                     {"clock_offset_us", host.clock_offset_us},
                     {"clock_uncertainty_us", host.clock_uncertainty_us},
                     {"cameras", cameras}});
  }
  return {{"host", fleet.host()}, {"hosts", hosts}};
}

// A capture or latency probe for any camera of the fleet (see the header comment).
void submit_camera_job(Fleet& fleet, const std::string& kind, const ApiRequest& request,
                       const PathParams& params, const Reply& reply) {
  auto target = fleet.resolve(params.at("id"));
  if (!target) return reply(error_response(target.error()));
  nlohmann::json body = nlohmann::json::object();
  int frames_total = 0;
  if (kind == "capture") {
    auto parsed = parse_json_object(request.body);
    if (!parsed) return reply(error_response(parsed.error()));
    body = std::move(*parsed);
  }
  if (!target->available)
    return reply(error_response(
        "no_device",
        "camera " + target->fleet_id() + " is not available: " + target->unavailable_reason));
  if (kind == "capture") {
    auto plan = fleet.plan(*target, body);
    if (!plan) return reply(error_response(plan.error()));
    frames_total = plan->total_frames();
  }
  auto job = fleet.submit(*target, kind, body, frames_total);
  if (!job) return reply(error_response(job.error()));
  reply(accepted_job(*job));
}

// 307 to the same request on host `host`, or host_unavailable while it is not serving.
ApiResponse redirect_to(Fleet& fleet, const std::string& host, const ApiRequest& request) {
  auto url = fleet.url_of(host);
  if (!url) return error_response(url.error());
  const std::string location =
      *url + request.path + (request.query.empty() ? "" : "?" + request.query);
  ApiResponse response = json_response(307, {{"host", host}, {"location", location}});
  response.headers.emplace_back("Location", location);
  return response;
}

void wrap_for_the_fleet(Router& router, const ServiceContext& context) {
  Fleet& fleet = *context.fleet;
  for (const char* kind : {"capture", "latency_probe"}) {
    const std::string pattern = std::string("/v1/cameras/{id}/") +
                                (std::string(kind) == "capture" ? "captures" : "latency-probe");
    router.wrap("POST", pattern,
                [&fleet, kind = std::string(kind)](
                    const ApiRequest& request, const PathParams& params, Reply reply,
                    const Handler&) { submit_camera_job(fleet, kind, request, params, reply); });
  }
  // What acts on a camera itself (its live view, histogram, controls) is its host's: a
  // bare id or CAMERA@THIS-HOST is served here, another host's camera redirected there.
  for (const auto& [method, pattern] :
       {std::pair<const char*, const char*>{"GET", "/v1/cameras/{id}/live"},
        {"GET", "/v1/cameras/{id}/live/frame"},
        {"GET", "/v1/cameras/{id}/histogram"},
        {"PUT", "/v1/cameras/{id}/controls"}})
    router.wrap(method, pattern,
                [&fleet](const ApiRequest& request, const PathParams& params, Reply reply,
                         const Handler& next) {
                  const auto [camera_id, host] = split_fleet_camera_id(params.at("id"));
                  if (!host.empty() && host != fleet.host())
                    return reply(redirect_to(fleet, host, request));
                  PathParams local = params;
                  local["id"] = camera_id;
                  next(request, local, std::move(reply));
                });
  router.wrap("GET", "/v1/cameras/{id}",
              [&fleet](const ApiRequest& request, const PathParams& params, Reply reply,
                       const Handler& next) {
                const auto [camera_id, host] = split_fleet_camera_id(params.at("id"));
                if (host.empty() || host == fleet.host()) {
                  PathParams local = params;
                  local["id"] = camera_id;
                  return next(request, local, std::move(reply));
                }
                auto target = fleet.resolve(params.at("id"));
                if (!target) return reply(error_response(target.error()));
                nlohmann::json json = target->description;
                json["id"] = target->fleet_id();
                json["camera_id"] = target->camera_id;
                json["host"] = target->host;
                json["available"] = target->available;
                reply(json_response(200, json));
              });
  router.wrap("DELETE", "/v1/jobs/{id}",
              [&fleet, context](const ApiRequest& request, const PathParams& params, Reply reply,
                                const Handler& next) {
                auto job = find_job(context, params, reply);
                if (!job) return;
                if (job->kind == "sync_capture" && !is_finished(job->state) &&
                    fleet.sync().cancel(job->id)) {
                  nlohmann::json json = to_json(*job);
                  json["cancel_requested"] = true;
                  return reply(json_response(202, json));
                }
                // What a worker stops between its steps; anything else running (a calibration
                // session: its own endpoints end it) is answered as on its host.
                const bool stoppable = job->kind == "capture" || job->kind == "latency_probe" ||
                                       job->kind == "calibration" || job->kind == "analysis";
                if (stoppable && !job->host.empty() && job->host != fleet.host() &&
                    job->state == JobState::kRunning) {
                  auto asked = fleet.store().request_cancel(job->id);
                  if (!asked) return reply(error_response(asked.error()));
                  if (*asked) {
                    nlohmann::json json = to_json(*job);
                    json["cancel_requested"] = true;
                    return reply(json_response(202, json));
                  }
                }
                next(request, params, std::move(reply));
              });
  // A job's files (frames, thumbnails, plots) are on the host that ran it.
  for (const char* pattern :
       {"/v1/jobs/{id}/frames", "/v1/jobs/{id}/frames/{n}", "/v1/jobs/{id}/frames/{n}/meta",
        "/v1/jobs/{id}/frames/{n}/thumbnail", "/v1/jobs/{id}/frames/{n}/region",
        "/v1/jobs/{id}/plots", "/v1/jobs/{id}/plots/{name}", "/v1/jobs/{id}/files",
        "/v1/jobs/{id}/files/{name}", "/v1/jobs/{id}/files/{dir}/{name}"})
    router.wrap("GET", pattern,
                [&fleet, context](const ApiRequest& request, const PathParams& params, Reply reply,
                                  const Handler& next) {
                  auto job = find_job(context, params, reply);
                  if (!job) return;
                  if (job->host.empty() || job->host == fleet.host())
                    return next(request, params, std::move(reply));
                  reply(redirect_to(fleet, job->host, request));
                });
}

}  // namespace

void add_fleet_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/fleet",
              "The fleet: hosts with their leases, clock offsets and cameras (CAMERA@HOST)",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                if (!context.fleet) return reply(error_response(not_in_a_fleet()));
                if (Status read = context.fleet->registry().refresh(); !read)
                  return reply(error_response(read.error()));
                reply(json_response(200, fleet_json(*context.fleet)));
              }});
  router.add({"POST", "/v1/sync-captures",
              "A synchronised capture: cameras on several hosts start at a common time (202 "
              "with the job; its result compares the frames' start times)",
              [context](const ApiRequest& request, const PathParams&, Reply reply) {
                // A fleet's cameras on any host, else this camlabd's own.
                SyncCaptures* sync = context.fleet ? &context.fleet->sync() : context.sync;
                if (!sync) return reply(error_response(not_in_a_fleet()));
                auto body = parse_json_object(request.body);
                if (!body) return reply(error_response(body.error()));
                auto job = sync->submit(*body);
                if (!job) return reply(error_response(job.error()));
                reply(accepted_job(*job));
              }});
  if (context.fleet) wrap_for_the_fleet(router, context);
}

}  // namespace camlab::service
