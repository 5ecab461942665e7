// POST /v1/test/cameras/{id}/faults: fault injection into an in-process virtual camera,
// for tests. Registered only with --test-faults (off by default); marked "x-test-only"
// in the OpenAPI document.
//
// Body (every field optional): {"unplug": true, "replug": true, "fail_next_dequeues": 3,
// "drop_next_frames": 5, "stall": true | false}. A replug is announced to the camera set
// at once, as the kernel's hot-plug event would be (CameraSet::notify_hotplug).
#include "service/api/service_context.h"
#include "service/jobs/camera_set.h"

namespace camlab::service {

namespace {

Result<int> bounded_count(const nlohmann::json& body, const char* name) {
  if (!body.contains(name)) return 0;
  const auto& v = body[name];
  if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 10000)
    return make_error("out_of_range", std::string(name) + " must be an integer in [0, 10000]");
  return static_cast<int>(v.get<int64_t>());
}

// The in-process virtual device of the camera in the path, or null once the reply says
// why not (no such camera: 404; another kind of camera: `unsupported`).
mock::VirtualV4l2Device* virtual_device_or_reply(const ServiceContext& context,
                                                 const PathParams& params,
                                                 const std::string& unsupported,
                                                 const Reply& reply) {
  if (!context.cameras->find(params.at("id"))) {
    reply(error_response("not_found", "no camera '" + params.at("id").substr(0, 100) + "'"));
    return nullptr;
  }
  mock::VirtualV4l2Device* device = context.cameras->virtual_device(params.at("id"));
  if (!device) reply(error_response("unsupported", unsupported));
  return device;
}

}  // namespace

void add_test_routes(Router& router, const ServiceContext& context) {
  Route route{
      "POST", "/v1/test/cameras/{id}/faults",
      "TEST ONLY (--test-faults): inject faults into an in-process virtual camera",
      [context](const ApiRequest& request, const PathParams& params, Reply reply) {
        mock::VirtualV4l2Device* device = virtual_device_or_reply(
            context, params, "faults can be injected only into in-process virtual cameras", reply);
        if (!device) return;
        auto body = parse_json_object(request.body);
        if (!body) return reply(error_response(body.error()));
        for (const auto& [key, value] : body->items())
          if (key != "unplug" && key != "replug" && key != "fail_next_dequeues" &&
              key != "drop_next_frames" && key != "stall")
            return reply(
                error_response("invalid_request", "unknown fault '" + key.substr(0, 40) +
                                                      "' (unplug, replug, fail_next_dequeues, "
                                                      "drop_next_frames, stall)"));
        auto fail = bounded_count(*body, "fail_next_dequeues");
        if (!fail) return reply(error_response(fail.error()));
        auto drop = bounded_count(*body, "drop_next_frames");
        if (!drop) return reply(error_response(drop.error()));
        for (const char* flag : {"unplug", "replug", "stall"})
          if (body->contains(flag) && !(*body)[flag].is_boolean())
            return reply(
                error_response("invalid_request", std::string(flag) + " must be true or false"));
        if (*fail > 0) device->fail_next_dequeues(*fail);
        if (*drop > 0) device->drop_next_frames(*drop);
        if (body->contains("stall")) device->stall((*body)["stall"].get<bool>());
        if (body->value("unplug", false)) device->unplug();
        if (body->value("replug", false)) {
          device->replug();
          context.cameras->notify_hotplug();
        }
        reply(json_response(200, {{"camera_id", params.at("id")}, {"injected", *body}}));
      }};
  route.test_only = true;
  router.add(std::move(route));

  // {"target": "board", "pose": [rx, ry, rz, tx, ty, tz]} (or a pose object as in a scene
  // spec): moves a scene target, as a person moves the board between shots.
  Route move{
      "POST", "/v1/test/cameras/{id}/scene",
      "TEST ONLY (--test-faults): move a target of an in-process virtual camera's scene",
      [context](const ApiRequest& request, const PathParams& params, Reply reply) {
        mock::VirtualV4l2Device* device = virtual_device_or_reply(
            context, params, "only an in-process virtual camera's scene can be moved", reply);
        if (!device) return;
        auto body = parse_json_object(request.body);
        if (!body) return reply(error_response(body.error()));
        for (const auto& [key, value] : body->items())
          if (key != "target" && key != "pose")
            return reply(error_response(
                "invalid_request", "unknown field '" + key.substr(0, 40) + "' (target, pose)"));
        if (!body->contains("target") || !(*body)["target"].is_string() || !body->contains("pose"))
          return reply(
              error_response("invalid_request", "give \"target\" (a target's name) and \"pose\""));
        auto pose = mock::parse_target_pose((*body)["pose"], "pose");
        if (!pose) return reply(error_response(pose.error()));
        if (Status s = device->set_target_pose((*body)["target"].get<std::string>(), *pose); !s)
          return reply(error_response(s.error()));
        reply(json_response(200, {{"camera_id", params.at("id")}, {"moved", *body}}));
      }};
  move.test_only = true;
  router.add(std::move(move));
}

}  // namespace camlab::service
