// Cameras: list, describe, set controls, queue captures and latency probes. Handlers read
// the worker's snapshot and never touch a camera: control changes run on the camera's
// worker as a task and answer when it is done; captures are queued as jobs (202).
#include <memory>

#include "capture/capture_plan.h"
#include "device/camera_json.h"
#include "service/api/api_lookup.h"
#include "service/api/service_context.h"
#include "service/jobs/camera_set.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

nlohmann::json latency_json(const ServiceContext& context, const std::string& id) {
  auto stored = context.store->latency(id);
  if (!stored || !stored->has_value()) return nullptr;
  return {{"frames", (*stored)->latency_frames},
          {"source", (*stored)->source},
          // When it was measured (Unix time, ms): named for what it holds (it was
          // "measured_ms", which reads as a duration).
          {"measured_at_unix_ms", (*stored)->measured_ms}};
}

nlohmann::json summary_json(const ServiceContext& context, const CameraSnapshot& s) {
  nlohmann::json json = device::to_json(s.identity);
  json["transport"] = s.transport;
  json["available"] = s.available;
  if (!s.available) json["unavailable_reason"] = s.unavailable_reason;
  json["present"] = !s.gone;
  if (s.gone) json["gone_since_ms"] = s.gone_since_ms;
  if (!s.also_reachable_as.empty()) json["also_reachable_as"] = s.also_reachable_as;
  json["running_job"] = s.running_job ? nlohmann::json(s.running_job) : nlohmann::json(nullptr);
  json["queued_jobs"] = s.queued_jobs;
  json["control_latency"] = latency_json(context, s.identity.id);
  // The worker stores the latency and then clears its flag: between the two a listing
  // showed both the latency and "measuring" (a test read it so under load). Once it is
  // known it is no longer being measured; a job posted then waits for the worker anyway.
  json["measuring_latency"] = s.measuring_latency && json["control_latency"].is_null();
  return json;
}

// A requested control value checked against the camera's range, step, type and menu;
// the message names the allowed range and unit.
Result<int64_t> check_control(const device::ControlInfo& c, const nlohmann::json& value) {
  int64_t v = 0;
  if (value.is_boolean() && c.type == device::ControlType::kBoolean)
    v = value.get<bool>() ? 1 : 0;
  else if (value.is_number_integer())
    v = value.get<int64_t>();
  else
    return make_error("invalid_request", "control '" + c.name + "' needs an integer value");
  const std::string unit = c.unit.empty() ? "" : " (unit: " + c.unit + ")";
  if (c.read_only) return make_error("unsupported", "control '" + c.name + "' is read-only");
  if (v < c.minimum || v > c.maximum)
    return make_error("out_of_range", "control '" + c.name + "' = " + std::to_string(v) +
                                          " is outside the allowed range [" +
                                          std::to_string(c.minimum) + ", " +
                                          std::to_string(c.maximum) + "]" + unit);
  if (c.step > 1 && (v - c.minimum) % c.step != 0)
    return make_error("out_of_range", "control '" + c.name + "' = " + std::to_string(v) +
                                          " is not on its step of " + std::to_string(c.step) +
                                          " from " + std::to_string(c.minimum) +
                                          " (allowed range [" + std::to_string(c.minimum) + ", " +
                                          std::to_string(c.maximum) + "])" + unit);
  if (!c.menu.empty()) {
    bool listed = false;
    std::string items;
    for (const auto& [value_of_item, name] : c.menu) {
      listed = listed || value_of_item == v;
      items += (items.empty() ? "" : ", ") + std::to_string(value_of_item) + " (" + name + ")";
    }
    if (!listed)
      return make_error("out_of_range", "control '" + c.name + "' = " + std::to_string(v) +
                                            " is not one of " + items);
  }
  return v;
}

void put_controls(const ServiceContext& context, const ApiRequest& request,
                  const PathParams& params, Reply reply) {
  auto worker = find_camera(context, params.at("id"), reply);
  if (!worker) return;
  auto body = parse_json_object(request.body);
  if (!body) return reply(error_response(body.error()));
  const nlohmann::json& wanted = body->contains("controls") ? (*body)["controls"] : *body;
  if (!wanted.is_object() || wanted.empty())
    return reply(error_response(
        "invalid_request",
        "send an object of control names and values, e.g. {\"exposure_time_absolute\": 100}"));
  if (wanted.size() > 64)
    return reply(error_response("invalid_request", "at most 64 controls per request"));
  const CameraSnapshot snapshot = worker->snapshot();
  if (!snapshot.available)
    return reply(error_response("no_device", "camera " + worker->id() + " is not available: " +
                                                 snapshot.unavailable_reason));
  if (snapshot.running_job)
    return reply(error_response("busy", "camera " + worker->id() + " is running job " +
                                            std::to_string(snapshot.running_job) +
                                            "; change controls when it is idle"));
  std::vector<std::pair<std::string, int64_t>> values;
  for (const auto& [name, value] : wanted.items()) {
    const device::ControlInfo* found = nullptr;
    std::string names;
    for (const auto& c : snapshot.controls) {
      if (c.name == name) found = &c;
      if (c.type != device::ControlType::kOther && c.type != device::ControlType::kButton)
        names += (names.empty() ? "" : ", ") + c.name;
    }
    if (!found)
      return reply(error_response("unsupported", "camera " + worker->id() + " has no control '" +
                                                     clip(name) + "' (controls: " + names + ")"));
    auto checked = check_control(*found, value);
    if (!checked) return reply(error_response(checked.error()));
    values.emplace_back(name, *checked);
  }
  // The answer goes once the camera's snapshot holds the new values, so that a GET right
  // after it reads them back.
  auto answer = std::make_shared<ApiResponse>();
  auto status = worker->post_task(
      [values, answer](device::Camera* camera, const Error* unavailable) {
        if (!camera) {
          *answer = error_response(*unavailable);
          return;
        }
        nlohmann::json applied = nlohmann::json::object();
        for (const auto& [name, value] : values) {
          auto result = camera->set_control(name, value);
          if (!result) {
            *answer = error_response(result.error());
            return;
          }
          applied[name] = {{"requested", value}, {"applied", *result}};
        }
        *answer = json_response(200, {{"controls", applied}});
      },
      [answer, reply] { reply(std::move(*answer)); });
  if (!status) reply(error_response(status.error()));
}

// Stores a job and queues it on the camera; 202 with the job and its Location.
void queue_job(const ServiceContext& context, const std::shared_ptr<CameraWorker>& worker,
               const std::string& kind, const nlohmann::json& request, int frames_total,
               const Reply& reply) {
  auto job = worker->store_and_enqueue(*context.store, kind, request, frames_total);
  if (!job) return reply(error_response(job.error()));
  ApiResponse response = json_response(202, to_json(*job));
  response.headers.emplace_back("Location", "/v1/jobs/" + std::to_string(job->id));
  reply(std::move(response));
}

void post_capture(const ServiceContext& context, const ApiRequest& request,
                  const PathParams& params, Reply reply) {
  auto worker = find_camera(context, params.at("id"), reply);
  if (!worker) return;
  auto body = parse_json_object(request.body);
  if (!body) return reply(error_response(body.error()));
  const CameraSnapshot snapshot = worker->snapshot();
  if (!snapshot.available) {
    // Have the worker try to open it again (it may be back), for the next request.
    if (!snapshot.gone) (void)worker->post_task([](device::Camera*, const Error*) {});
    return reply(error_response("no_device", "camera " + worker->id() + " is not available: " +
                                                 snapshot.unavailable_reason));
  }
  // Validated here against the snapshot, so a bad request gets its 400/422 now rather
  // than a failed job later; the worker plans again against the camera as it is then.
  auto plan = capture::plan_capture(*body, snapshot.controls, snapshot.formats, snapshot.traits);
  if (!plan) return reply(error_response(plan.error()));
  queue_job(context, worker, "capture", *body, plan->total_frames(), reply);
}

}  // namespace

void add_camera_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/cameras",
              "Every camera with its availability, running job and control latency",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                nlohmann::json cameras = nlohmann::json::array();
                for (const auto& worker : context.cameras->workers())
                  cameras.push_back(summary_json(context, worker->snapshot()));
                reply(json_response(200, {{"cameras", cameras}}));
              }});
  router.add({"GET", "/v1/cameras/{id}",
              "One camera: formats, sizes, frame rates, controls with ranges and units",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                auto worker = find_camera(context, params.at("id"), reply);
                if (!worker) return;
                const CameraSnapshot s = worker->snapshot();
                nlohmann::json json = s.description;
                const nlohmann::json summary = summary_json(context, s);
                for (const auto& [key, value] : summary.items()) json[key] = value;
                reply(json_response(200, json));
              }});
  router.add({"PUT", "/v1/cameras/{id}/controls",
              "Set controls (by V4L2 name, in the control's unit); 422 names the range",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                put_controls(context, request, params, std::move(reply));
              }});
  router.add({"POST", "/v1/cameras/{id}/captures",
              "Queue a capture (single, bracket, focus_stack, aperture_series, lens_map): 202 with "
              "the job",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                post_capture(context, request, params, std::move(reply));
              }});
  router.add({"POST", "/v1/cameras/{id}/latency-probe",
              "Queue a control-latency probe (stepping exposure, watching the mean signal): 202 "
              "with the job",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                auto worker = find_camera(context, params.at("id"), reply);
                if (!worker) return;
                queue_job(context, worker, "latency_probe", nlohmann::json::object(), 0, reply);
              }});
}

}  // namespace camlab::service
