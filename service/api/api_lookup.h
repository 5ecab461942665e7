// What several groups of routes look up by path parameter: a camera's worker by {id}, a
// job by {id}. Each answers the request itself (404, 400) when there is none.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "image/capture_folder.h"
#include "service/api/api_types.h"
#include "service/store/job_store.h"

namespace camlab::service {

class CameraWorker;
struct ServiceContext;

// `s` cut to 100 characters for an error message (an id or name a client sent).
std::string clip(const std::string& s);

// The worker of camera `id` (a retired one while the camera is gone), or nullptr after a
// 404 reply that lists the cameras.
std::shared_ptr<CameraWorker> find_camera(const ServiceContext& context, const std::string& id,
                                          const Reply& reply);

// Whether `relative` (a job's folder, maybe with a subfolder) leads from the data folder
// through real folders only: a job folder replaced by a symlink is not followed.
bool within_data_dir(const std::filesystem::path& data_dir, const std::filesystem::path& relative);

// A file read whole: O_NOFOLLOW and a regular file only (a file replaced by a symlink, to
// the token say, or by a device or FIFO is refused, not followed).
bool read_bytes(const std::filesystem::path& path, std::string* out);

// The job named by the {id} parameter, or nullopt after a 400/404/500 reply.
std::optional<JobRecord> find_job(const ServiceContext& context, const PathParams& params,
                                  const Reply& reply);

// A stored frame named by a route's {id} and {n}: the capture job's folder and the index.
struct JobFrameRef {
  std::filesystem::path dir;  // the capture folder, inside the data folder
  int index = 0;
  int64_t job_id = 0;
};

// The frame the {id} and {n} parameters name, or nullopt after a 400/404/422 reply (not a
// capture job, a bad index, a folder that is missing or a symlink). Reads no frame.
std::optional<JobFrameRef> find_job_frame(const ServiceContext& context, const PathParams& params,
                                          const Reply& reply);

struct StoredFrame {
  image::FrameSidecar sidecar;
  cv::Mat image;  // the DN as stored
};

// The frame and its sidecar, read whole on the caller's thread (a live-hub task: never an
// HTTP thread). Errors "not_found" (no frames yet, fewer frames than the index), or the
// folder's own (a broken PNG, a sidecar that does not parse).
Result<StoredFrame> read_stored_frame(const JobFrameRef& frame);

}  // namespace camlab::service
