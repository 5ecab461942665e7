// The raw values of a rectangle of a stored frame, for the dashboard's viewer: the DN
// under the cursor and an ROI's statistics per channel (analysis/region_stats.h). The
// frame is read on the live hub's thread, as thumbnails are, never on an HTTP thread.
#include <cmath>
#include <string>

#include "analysis/region_stats.h"
#include "image/capture_folder.h"
#include "service/api/api_lookup.h"
#include "service/api/service_context.h"
#include "service/live/live_hub.h"

namespace camlab::service {

namespace {

// A frame is at most this wide or high (the largest a V4L2 driver reports is 16384).
constexpr double kMaxFrameSidePx = 65536;

Result<int> query_integer(const QueryParams& query, const std::string& name, double min,
                          double fallback) {
  double value = 0;
  CAMLAB_ASSIGN(value, query_number(query, name, min, kMaxFrameSidePx, fallback));
  if (value != std::floor(value))
    return make_error("invalid_request", "'" + name + "' is a whole number of pixels");
  return static_cast<int>(value);
}

nlohmann::json region_json(const analysis::RegionStats& stats, const image::FrameSidecar& s,
                           int width_px, int height_px) {
  nlohmann::json channels = nlohmann::json::array();
  for (const auto& c : stats.channels)
    channels.push_back({{"channel", c.channel},
                        {"samples", c.samples},
                        {"mean_dn", c.mean_dn},
                        {"sd_dn", c.sd_dn},
                        {"snr", c.snr ? nlohmann::json(*c.snr) : nlohmann::json(nullptr)},
                        {"min_dn", c.min_dn},
                        {"max_dn", c.max_dn}});
  nlohmann::json samples = nlohmann::json::array();
  for (const auto& v : stats.samples)
    samples.push_back({{"x", v.x}, {"y", v.y}, {"channel", v.channel}, {"dn", v.dn}});
  return {{"x", stats.rect.x},
          {"y", stats.rect.y},
          {"width", stats.rect.width},
          {"height", stats.rect.height},
          {"frame_width", width_px},
          {"frame_height", height_px},
          {"pixel_format", s.pixel_format},
          {"cfa_pattern", s.cfa_pattern},
          {"bit_depth", s.bit_depth},
          {"black_level_dn", s.black_level_dn},
          {"white_level_dn", s.white_level_dn},
          {"linear", s.linear},
          {"channels", channels},
          {"samples", samples}};
}

void get_frame_region(const ServiceContext& context, const ApiRequest& request,
                      const PathParams& params, Reply reply) {
  if (!context.live)
    return reply(error_response("unsupported", "this camlabd reads no frame regions"));
  const QueryParams query = parse_query(request.query);
  auto x = query_integer(query, "x", 0, 0);
  auto y = query_integer(query, "y", 0, 0);
  auto width = query_integer(query, "width", 1, 1);
  auto height = query_integer(query, "height", 1, 1);
  for (const auto* part : {&x, &y, &width, &height})
    if (!*part) return reply(error_response(part->error()));
  auto ref = find_job_frame(context, params, reply);
  if (!ref) return;
  const cv::Rect rect(*x, *y, *width, *height);
  const bool posted = context.live->post([ref = *ref, rect, reply] {
    auto stored = read_stored_frame(ref);
    if (!stored) return reply(error_response(stored.error()));
    auto stats = analysis::region_stats(stored->image, stored->sidecar, rect);
    if (!stats) return reply(error_response(stats.error()));
    reply(json_response(
        200, region_json(*stats, stored->sidecar, stored->image.cols, stored->image.rows)));
  });
  if (!posted) reply(error_response("shutting_down", "camlabd is shutting down"));
}

}  // namespace

void add_frame_region_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/jobs/{id}/frames/{n}/region",
              "Raw DN of a rectangle of frame n (?x=, ?y=, ?width=, ?height= px): per channel "
              "mean, sd, SNR, range; each sample when it holds at most 64",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_frame_region(context, request, params, std::move(reply));
              }});
}

}  // namespace camlab::service
