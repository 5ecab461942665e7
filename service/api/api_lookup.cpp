#include "service/api/api_lookup.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

#include "base/unique_fd.h"
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

// Whether `relative` (a job's folder, maybe with a subfolder) leads from the data folder
// through real folders only: a job folder replaced by a symlink (to /etc, or another
// user's captures) is not followed, as a frame file replaced by one is not (read_bytes).
bool within_data_dir(const std::filesystem::path& data_dir, const std::filesystem::path& relative) {
  std::filesystem::path at = data_dir;
  std::error_code ec;
  for (const auto& part : relative) {
    if (part.empty() || part == "." || part == "..") return false;
    at /= part;
    const auto status = std::filesystem::symlink_status(at, ec);
    if (ec || std::filesystem::is_symlink(status)) return false;
  }
  return true;
}

// A file, read whole. O_NOFOLLOW, and a regular file only: a frame replaced by a
// symlink (to the token, say) or by a device or FIFO is refused, not followed.
bool read_bytes(const std::filesystem::path& path, std::string* out) {
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK));
  struct stat info {};
  if (!fd || ::fstat(fd.get(), &info) != 0 || !S_ISREG(info.st_mode)) return false;
  out->resize(static_cast<size_t>(info.st_size));
  size_t done = 0;
  while (done < out->size()) {
    const ssize_t n = ::read(fd.get(), out->data() + done, out->size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;  // an error, or the file shrank while read
    done += static_cast<size_t>(n);
  }
  return true;
}

std::optional<JobFrameRef> find_job_frame(const ServiceContext& context, const PathParams& params,
                                          const Reply& reply) {
  auto job = find_job(context, params, reply);
  if (!job) return std::nullopt;
  auto n = parse_id(params.at("n"), "the frame index", 9);
  if (!n) {
    reply(error_response(n.error()));
    return std::nullopt;
  }
  if (job->kind != "capture" || job->folder.empty()) {
    reply(error_response("no_frames", "job " + std::to_string(job->id) + " is a " + job->kind +
                                          " job; only capture jobs have frames"));
    return std::nullopt;
  }
  if (!within_data_dir(context.data_dir, job->folder)) {
    reply(error_response("not_found", "job " + std::to_string(job->id) +
                                          "'s folder is missing or a symlink, which is not "
                                          "followed"));
    return std::nullopt;
  }
  return JobFrameRef{context.data_dir / job->folder, static_cast<int>(*n), job->id};
}

Result<StoredFrame> read_stored_frame(const JobFrameRef& frame) {
  const std::string job = "job " + std::to_string(frame.job_id);
  auto folder = image::CaptureFolder::open(frame.dir);
  if (!folder) return make_error("not_found", job + " has no frames yet");
  const int count = static_cast<int>(folder->frames().size());
  if (frame.index >= count)
    return make_error("not_found", job + " has " + std::to_string(count) + " frames; no frame " +
                                       std::to_string(frame.index));
  StoredFrame out;
  CAMLAB_ASSIGN(out.sidecar, folder->load_sidecar(frame.index));
  CAMLAB_ASSIGN(out.image, folder->load_stored_image(frame.index));
  return out;
}

}  // namespace camlab::service
