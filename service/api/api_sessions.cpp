// Guided calibration sessions (service/jobs/calibration_sessions.h):
//
//   POST   /v1/calibration-sessions              {"camera": ID, board, detector, model,
//                                                 "target_uncertainty_px": 0.5} -> 201
//   GET    /v1/calibration-sessions/{id}         the state: views, solve, uncertainty, suggestion
//   POST   /v1/calibration-sessions/{id}/views   take a view (a capture, then detect and solve) ->
//   202 POST   /v1/calibration-sessions/{id}/finish  calibrate on every view -> 202 DELETE
//   /v1/calibration-sessions/{id}         cancel
#include "service/api/service_context.h"
#include "service/jobs/calibration_request.h"
#include "service/jobs/calibration_sessions.h"

namespace camlab::service {

namespace {

// A router built without the session manager (a test of the routes alone).
bool sessions_available(const ServiceContext& context, const Reply& reply) {
  if (context.sessions) return true;
  reply(error_response("shutting_down", "calibration sessions are not served by this router"));
  return false;
}

void post_session(const ServiceContext& context, const ApiRequest& request, Reply reply) {
  if (!sessions_available(context, reply)) return;
  auto body = parse_json_object(request.body);
  if (!body) return reply(error_response(body.error()));
  if (Status known =
          check_known_fields(*body, {"camera", "inner_corners", "spacing_m", "detector", "marker_m",
                                     "dictionary", "model", "pixel_um", "target_uncertainty_px"});
      !known)
    return reply(error_response(known.error()));
  const nlohmann::json& camera = body->value("camera", nlohmann::json());
  if (!camera.is_string() || camera.get<std::string>().empty() ||
      camera.get<std::string>().size() > 200)
    return reply(error_response("invalid_request",
                                "\"camera\" must be a camera id (GET /v1/cameras lists them)"));
  auto normalised = normalised_calibration_fields(*body);
  if (!normalised) return reply(error_response(normalised.error()));
  const nlohmann::json& target = body->value("target_uncertainty_px", nlohmann::json(0.5));
  if (!target.is_number() || !(target.get<double>() >= 0.01) || target.get<double>() > 100)
    return reply(error_response(
        "out_of_range",
        "target_uncertainty_px (the worst projection uncertainty over the imager at which the "
        "session has enough views, px) must be in [0.01, 100]"));
  (*normalised)["target_uncertainty_px"] = target;
  auto opened = context.sessions->open(camera.get<std::string>(), *normalised);
  if (!opened) return reply(error_response(opened.error()));
  ApiResponse response = json_response(201, *opened);
  response.headers.emplace_back(
      "Location", "/v1/calibration-sessions/" + std::to_string((*opened)["id"].get<int64_t>()));
  reply(std::move(response));
}

// Runs `action` on the session named by the path, answering `status` with its state.
template <class Action>
void on_session(const ServiceContext& context, const PathParams& params, int status,
                const Reply& reply, Action action) {
  if (!sessions_available(context, reply)) return;
  auto id = parse_id(params.at("id"), "session id");
  if (!id) return reply(error_response(id.error()));
  Result<nlohmann::json> state = action(*id);
  if (!state) return reply(error_response(state.error()));
  reply(json_response(status, *state));
}

}  // namespace

void add_session_routes(Router& router, const ServiceContext& context) {
  router.add({"POST", "/v1/calibration-sessions",
              "Open a guided calibration on a camera: 201 with the session (views are taken "
              "with POST .../views)",
              [context](const ApiRequest& request, const PathParams&, Reply reply) {
                post_session(context, request, std::move(reply));
              }});
  router.add({"GET", "/v1/calibration-sessions/{id}",
              "A session's state: frames, solve, uncertainty over the imager, next suggested view",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                on_session(context, params, 200, reply,
                           [&](int64_t id) { return context.sessions->state(id); });
              }});
  router.add({"POST", "/v1/calibration-sessions/{id}/views",
              "Take a view: capture a frame, detect, solve, suggest the next: 202 (poll until "
              "phase is ready)",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                on_session(context, params, 202, reply,
                           [&](int64_t id) { return context.sessions->take_view(id); });
              }});
  router.add({"POST", "/v1/calibration-sessions/{id}/finish",
              "Calibrate on every view into a .cameramodel and a report: 202 (poll until ended)",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                on_session(context, params, 202, reply,
                           [&](int64_t id) { return context.sessions->finish(id); });
              }});
  router.add({"DELETE", "/v1/calibration-sessions/{id}", "Cancel a session",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                on_session(context, params, 200, reply,
                           [&](int64_t id) { return context.sessions->cancel(id); });
              }});
}

}  // namespace camlab::service
