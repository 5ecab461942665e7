#include "service/api/api_lookup.h"

#include "service/api/service_context.h"
#include "service/jobs/camera_set.h"

namespace camlab::service {

// Reserved first: GCC 12 warns (-Warray-bounds, a false positive) on substr() + "...".
std::string clip(const std::string& s) {
  if (s.size() <= 100) return s;
  std::string first_100;
  first_100.reserve(103);
  first_100.append(s, 0, 100).append("...");
  return first_100;
}

std::shared_ptr<CameraWorker> find_camera(const ServiceContext& context, const std::string& id,
                                          const Reply& reply) {
  if (auto worker = context.cameras->find(id)) return worker;
  std::string known;
  for (const auto& w : context.cameras->workers()) known += (known.empty() ? "" : ", ") + w->id();
  reply(error_response("not_found", "no camera '" + clip(id) +
                                        "' (cameras: " + (known.empty() ? "none" : known) + ")"));
  return nullptr;
}

std::optional<JobRecord> find_job(const ServiceContext& context, const PathParams& params,
                                  const Reply& reply) {
  auto id = parse_id(params.at("id"), "the job id");
  if (!id) {
    reply(error_response(id.error()));
    return std::nullopt;
  }
  auto job = context.store->get(*id);
  if (!job) {
    reply(error_response(job.error()));
    return std::nullopt;
  }
  if (!job->has_value()) {
    reply(error_response("not_found", "no job " + std::to_string(*id)));
    return std::nullopt;
  }
  return std::move(**job);
}

}  // namespace camlab::service
