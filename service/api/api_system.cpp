// GET /v1/health (public), GET /metrics, GET /v1/openapi.json.
#include "service/api/service_context.h"
#include "service/jobs/camera_set.h"
#include "service/metrics.h"
#include "service/store/job_store.h"

namespace camlab::service {

void add_system_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/health", "Liveness: 200 while the daemon serves (no token needed)",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                int available = 0;
                const auto workers = context.cameras->workers();
                for (const auto& worker : workers) available += worker->snapshot().available;
                reply(json_response(200, {{"status", "ok"},
                                          {"cameras", workers.size()},
                                          {"cameras_available", available}}));
              },
              /*is_public=*/true});

  router.add({"GET", "/metrics", "Prometheus metrics (text format 0.0.4)",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                auto counts = context.store->count_by_state();
                ApiResponse response;
                response.content_type = "text/plain; version=0.0.4; charset=utf-8";
                response.body =
                    context.metrics->render(counts ? *counts : std::map<std::string, int64_t>{});
                reply(std::move(response));
              }});

  router.add({"GET", "/v1/openapi.json", "This API as an OpenAPI 3 document",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                reply(json_response(200, openapi_document(context.test_faults)));
              }});
}

void add_all_routes(Router& router, const ServiceContext& context) {
  add_system_routes(router, context);
  add_camera_routes(router, context);
  add_job_routes(router, context);
  add_job_file_routes(router, context);
  add_compute_routes(router, context);
  add_session_routes(router, context);
  add_live_routes(router, context);
  add_frame_region_routes(router, context);
  add_event_routes(router, context);
  add_web_routes(router, context);
  add_fleet_routes(router, context);
  if (context.test_faults) add_test_routes(router, context);
}

}  // namespace camlab::service
