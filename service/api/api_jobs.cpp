// Jobs: list, status, cancel, and the frames of a capture job (PNG and sidecar). Frame
// files are found only through the job's own folder (from the database) and the
// manifest's entries (plain file names, checked by CaptureFolder::open); the request
// supplies numbers only.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "base/unique_fd.h"
#include "image/capture_folder.h"
#include "service/api/api_lookup.h"
#include "service/api/service_context.h"
#include "service/fleet/sync_captures.h"
#include "service/jobs/camera_set.h"
#include "service/jobs/compute_jobs.h"
#include "service/jobs/job_waiters.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

constexpr int kMaxListLimit = 1000;

// The capture folder of a capture job, or a reply saying why there is none.
std::optional<image::CaptureFolder> job_folder(const ServiceContext& context, const JobRecord& job,
                                               const Reply& reply) {
  if (job.kind != "capture") {
    reply(error_response("no_frames", "job " + std::to_string(job.id) + " is a " + job.kind +
                                          " job; only capture jobs have frames"));
    return std::nullopt;
  }
  auto folder =
      within_data_dir(context.data_dir, job.folder)
          ? image::CaptureFolder::open(context.data_dir / job.folder)
          : Result<image::CaptureFolder>(make_error(
                "not_found", "its folder is missing or a symlink, which is not followed"));
  if (!folder) {
    if (job.state == JobState::kQueued) {
      reply(error_response("not_found",
                           "job " + std::to_string(job.id) + " is queued and has no frames yet"));
    } else {
      reply(error_response("not_found", "job " + std::to_string(job.id) +
                                            " has no capture folder (" + folder.error().message +
                                            ")"));
    }
    return std::nullopt;
  }
  return std::move(*folder);
}

// The frame index {n}: a number below the folder's frame count.
std::optional<int> frame_index(const image::CaptureFolder& folder, const JobRecord& job,
                               const PathParams& params, const Reply& reply) {
  auto n = parse_id(params.at("n"), "the frame index", 9);
  if (!n) {
    reply(error_response(n.error()));
    return std::nullopt;
  }
  const int count = static_cast<int>(folder.frames().size());
  if (*n >= count) {
    reply(error_response("not_found", "job " + std::to_string(job.id) + " has " +
                                          std::to_string(count) + " frames (0.." +
                                          std::to_string(count - 1) + "); no frame " +
                                          std::to_string(*n)));
    return std::nullopt;
  }
  return static_cast<int>(*n);
}

// Frame {n} of job {id}: its image or its sidecar file, read whole; replies with the
// error (unknown job, frame out of range, unreadable file) and returns nullopt otherwise.
std::optional<ApiResponse> read_frame_file(const ServiceContext& context, const PathParams& params,
                                           bool sidecar, const Reply& reply) {
  auto job = find_job(context, params, reply);
  if (!job) return std::nullopt;
  auto folder = job_folder(context, *job, reply);
  if (!folder) return std::nullopt;
  auto n = frame_index(*folder, *job, params, reply);
  if (!n) return std::nullopt;
  const auto& entry = folder->frames()[*n];
  ApiResponse response;
  if (!read_bytes(folder->dir() / (sidecar ? entry.sidecar_file : entry.image_file),
                  &response.body)) {
    reply(error_response("io_error", std::string("cannot read ") +
                                         (sidecar ? "the sidecar of " : "") + "frame " +
                                         std::to_string(*n)));
    return std::nullopt;
  }
  return response;
}

// GET /v1/jobs/{id}[?wait=S]: with wait, the answer comes once the job has finished or
// after S seconds (0..60, decimals allowed), whichever is first (service/jobs/job_waiters.h).
void get_job(const ServiceContext& context, const ApiRequest& request, const PathParams& params,
             Reply reply) {
  const auto query = parse_query(request.query);
  double wait_s = 0;
  if (auto it = query.find("wait"); it != query.end()) {
    const std::optional<double> parsed = parse_decimal(it->second);
    wait_s = parsed.value_or(-1);
    if (!parsed || !(wait_s >= 0) || wait_s > 60)
      return reply(error_response("invalid_request",
                                  "wait must be a number of seconds in [0, 60], e.g. ?wait=30"));
  }
  // Every waiting slot taken: 503 with Retry-After, before the store is read. Answering at
  // once with the job as it is sent a client that asks again straight away into a loop
  // that cost a store transaction a request (about 4,000/s with 186 such clients).
  if (wait_s > 0 && context.waiters && !context.waiters->has_room()) {
    ApiResponse busy = error_response(
        "too_many_connections",
        std::to_string(context.waiters->capacity()) +
            " requests already wait on jobs (a quarter of --max-connections); retry in a "
            "second, or ask without ?wait");
    busy.headers.emplace_back("Retry-After", "1");
    return reply(std::move(busy));
  }
  auto job = find_job(context, params, reply);
  if (!job) return;
  if (wait_s > 0 && !is_finished(job->state) && context.waiters) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
    const int64_t id = job->id;
    const bool waiting = context.waiters->wait(id, deadline, [reply, id](const JobRecord* now) {
      if (now)
        reply(json_response(200, to_json(*now)));
      else
        reply(error_response("not_found", "no job " + std::to_string(id)));
    });
    if (waiting) return;  // answered by the waiters; taken meanwhile: answer now
  }
  reply(json_response(200, to_json(*job)));
}

void list_jobs(const ServiceContext& context, const ApiRequest& request, Reply reply) {
  const auto query = parse_query(request.query);
  std::optional<JobState> state;
  int limit = 100, offset = 0;
  if (auto it = query.find("state"); it != query.end()) {
    state = parse_job_state(it->second);
    if (!state)
      return reply(error_response(
          "invalid_request",
          "state must be one of queued, running, succeeded, failed, cancelled, interrupted"));
  }
  if (auto it = query.find("limit"); it != query.end()) {
    auto n = parse_id(it->second, "limit", 6);
    if (!n || *n < 1 || *n > kMaxListLimit)
      return reply(error_response("invalid_request",
                                  "limit must be in [1, " + std::to_string(kMaxListLimit) + "]"));
    limit = static_cast<int>(*n);
  }
  if (auto it = query.find("offset"); it != query.end()) {
    auto n = parse_id(it->second, "offset", 9);
    if (!n) return reply(error_response(n.error()));
    offset = static_cast<int>(*n);
  }
  auto jobs = context.store->list(state, limit, offset);
  if (!jobs) return reply(error_response(jobs.error()));
  nlohmann::json list = nlohmann::json::array();
  for (const auto& job : *jobs) list.push_back(to_json(job));
  reply(json_response(200, {{"jobs", list}, {"limit", limit}, {"offset", offset}}));
}

void cancel_job(const ServiceContext& context, const PathParams& params, Reply reply) {
  auto job = find_job(context, params, reply);
  if (!job) return;
  if (job->state == JobState::kQueued) {
    auto cancelled = context.store->cancel_queued(job->id);
    if (!cancelled) return reply(error_response(cancelled.error()));
    if (*cancelled) {
      // The worker's queue still lists it: free its slot now (the worker would skip it
      // anyway, since the store no longer lets a cancelled job start).
      if (auto worker = job->camera_id.empty() ? nullptr : context.cameras->find(job->camera_id))
        worker->forget_queued(job->id);
      auto now = context.store->get(job->id);
      return reply(json_response(200, now && now->has_value() ? to_json(**now) : to_json(*job)));
    }
    auto now = context.store->get(job->id);  // it started meanwhile: cancel it running
    if (!now || !now->has_value())
      return reply(error_response("io_error", "job vanished while cancelling"));
    job = **now;
  }
  // A synchronised capture of this camlabd's cameras: each of its captures is cancelled.
  if (job->state == JobState::kRunning && job->kind == "sync_capture" && context.sync &&
      context.sync->cancel(job->id)) {
    nlohmann::json json = to_json(*job);
    json["cancel_requested"] = true;
    return reply(json_response(202, json));
  }
  if (job->state == JobState::kRunning) {
    auto worker = job->camera_id.empty() ? nullptr : context.cameras->find(job->camera_id);
    // A calibration or analysis stops between its steps (service/jobs/compute_jobs.h).
    const bool compute_cancelled =
        job->camera_id.empty() && context.compute && context.compute->cancel_running(job->id);
    if (compute_cancelled || (worker && worker->cancel_running(job->id))) {
      nlohmann::json json = to_json(*job);
      json["cancel_requested"] = true;
      return reply(json_response(202, json));
    }
    return reply(error_response("not_cancellable", "job " + std::to_string(job->id) + " (" +
                                                       job->kind +
                                                       ") cannot be cancelled once running"));
  }
  reply(error_response("conflict", "job " + std::to_string(job->id) + " has already finished (" +
                                       job_state_name(job->state) + ")"));
}

// The plots a calibration or analysis job wrote (its folder's plots/), as PNG files.
std::vector<std::string> plot_names(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file(ec) && entry.path().extension() == ".png" &&
        image::is_plain_file_name(name))
      names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

void list_plots(const ServiceContext& context, const PathParams& params, Reply reply) {
  auto job = find_job(context, params, reply);
  if (!job) return;
  nlohmann::json plots = nlohmann::json::array();
  if (!job->folder.empty() && job->kind != "capture" &&
      within_data_dir(context.data_dir, std::filesystem::path(job->folder) / "plots")) {
    const std::string base = "/v1/jobs/" + std::to_string(job->id) + "/plots/";
    const std::filesystem::path dir = context.data_dir / job->folder / "plots";
    for (const auto& name : plot_names(dir)) {
      nlohmann::json plot = {{"name", name}, {"image", base + name}};
      // The chart's data beside it (analysis/plot.h), for pages that draw it themselves.
      const std::string data = std::filesystem::path(name).replace_extension(".json").string();
      std::error_code ec;
      if (std::filesystem::is_regular_file(dir / data, ec))
        plot["data"] = "/v1/jobs/" + std::to_string(job->id) + "/files/plots/" + data;
      plots.push_back(std::move(plot));
    }
  }
  reply(json_response(200, {{"job_id", job->id},
                            {"kind", job->kind},
                            {"state", job_state_name(job->state)},
                            {"plots", plots}}));
}

void get_plot(const ServiceContext& context, const PathParams& params, Reply reply) {
  auto job = find_job(context, params, reply);
  if (!job) return;
  const std::string& name = params.at("name");
  const std::filesystem::path dir = context.data_dir / job->folder / "plots";
  if (job->folder.empty() || job->kind == "capture" || !image::is_plain_file_name(name) ||
      std::filesystem::path(name).extension() != ".png" ||
      !within_data_dir(context.data_dir, std::filesystem::path(job->folder) / "plots"))
    return reply(error_response("not_found", "job " + std::to_string(job->id) + " has no plot '" +
                                                 clip(name) + "' (GET /v1/jobs/" +
                                                 std::to_string(job->id) + "/plots lists them)"));
  ApiResponse response;
  if (!read_bytes(dir / name, &response.body))
    return reply(error_response(
        "not_found", "job " + std::to_string(job->id) + " has no plot '" + clip(name) + "'"));
  response.content_type = "image/png";
  reply(std::move(response));
}

}  // namespace

void add_job_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/jobs/{id}/plots",
              "The plots a calibration or analysis job drew (PNG): linearity, photon transfer, "
              "CoC against f-number, V-curve, depth map, residuals, uncertainty",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                list_plots(context, params, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs/{id}/plots/{name}", "One plot of a job, as PNG",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                get_plot(context, params, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs", "Jobs, newest first (?state=, ?limit= up to 1000, ?offset=)",
              [context](const ApiRequest& request, const PathParams&, Reply reply) {
                list_jobs(context, request, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs/{id}",
              "A job: state, progress, error, result; ?wait=S answers once it has finished or "
              "after S seconds (at most 60)",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_job(context, request, params, std::move(reply));
              }});
  router.add(
      {"DELETE", "/v1/jobs/{id}",
       "Cancel: a queued job at once (200), a running capture between frames (202; frames kept)",
       [context](const ApiRequest&, const PathParams& params, Reply reply) {
         cancel_job(context, params, std::move(reply));
       }});
  router.add({"GET", "/v1/jobs/{id}/frames", "The frames a capture job has written so far",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                auto job = find_job(context, params, reply);
                if (!job) return;
                // Queued, or started but still setting the camera up (the latency probe,
                // the format): no folder yet, and no frames, which is no error.
                const bool folder_pending =
                    job->kind == "capture" &&
                    (job->state == JobState::kQueued ||
                     (job->state == JobState::kRunning &&
                      !std::filesystem::exists(context.data_dir / job->folder / "manifest.json")));
                if (folder_pending)
                  return reply(json_response(200, {{"job_id", job->id},
                                                   {"state", job_state_name(job->state)},
                                                   {"complete", false},
                                                   {"frames", nlohmann::json::array()}}));
                auto folder = job_folder(context, *job, reply);
                if (!folder) return;
                nlohmann::json frames = nlohmann::json::array();
                const std::string base = "/v1/jobs/" + std::to_string(job->id) + "/frames/";
                for (size_t i = 0; i < folder->frames().size(); ++i)
                  frames.push_back({{"index", i},
                                    {"image", base + std::to_string(i)},
                                    {"meta", base + std::to_string(i) + "/meta"}});
                reply(json_response(200, {{"job_id", job->id},
                                          {"complete", folder->complete()},
                                          {"folder", job->folder},
                                          {"frames", frames}}));
              }});
  router.add({"GET", "/v1/jobs/{id}/frames/{n}",
              "Frame n as PNG (raw sensor DN; 16-bit above 8 bits)",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                auto response = read_frame_file(context, params, /*sidecar=*/false, reply);
                if (!response) return;
                response->content_type = "image/png";
                reply(std::move(*response));
              }});
  router.add({"GET", "/v1/jobs/{id}/frames/{n}/meta",
              "Frame n's sidecar: settings in effect, sequence, timestamp, frames discarded",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                auto response = read_frame_file(context, params, /*sidecar=*/true, reply);
                if (!response) return;
                reply(std::move(*response));
              }});
}

}  // namespace camlab::service
