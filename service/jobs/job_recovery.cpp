#include "service/jobs/job_recovery.h"

#include <system_error>

#include "base/atomic_file.h"
#include "base/log.h"
#include "image/capture_folder_recovery.h"
#include "service/store/fleet_store.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace fs = std::filesystem;

namespace {

// Far more than one run leaves unfinished: each camera's queue and the compute queue.
constexpr int kMaxUnfinishedJobs = 100000;

}  // namespace

Result<std::vector<RecoveredJob>> recover_unfinished_jobs(JobStore& store,
                                                          const fs::path& data_dir) {
  std::vector<JobRecord> unfinished;
  if (FleetStore* fleet = store.fleet()) {
    auto jobs = fleet->jobs_to_recover();
    if (!jobs) return jobs.error();
    unfinished = std::move(*jobs);
  } else {
    for (JobState state : {JobState::kRunning, JobState::kQueued}) {
      auto jobs = store.list(state, kMaxUnfinishedJobs, 0);
      if (!jobs) return jobs.error();
      unfinished.insert(unfinished.end(), jobs->begin(), jobs->end());
    }
  }
  std::vector<RecoveredJob> recovered;
  for (const JobRecord& job : unfinished) {
    if (job.folder.empty()) continue;
    const fs::path dir = data_dir / job.folder;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;  // queued, or killed before it made one
    RecoveredJob r{job.id, 0, job.frames_done, 0};
    if (job.kind == "capture") {
      auto folder = image::recover_capture_folder(dir);
      if (!folder) {
        log_warning(log::Category::kJobs, "job %lld: cannot recover %s: %s",
                    static_cast<long long>(job.id), dir.c_str(), folder.error().message.c_str());
        continue;
      }
      r.frames = folder->frames;
      r.files_removed = static_cast<int>(folder->removed.size());
      if (!folder->journal_problem.empty())
        log_warning(log::Category::kJobs, "job %lld: %llu bytes cut from %s's journal (%s)",
                    static_cast<long long>(job.id),
                    static_cast<unsigned long long>(folder->journal_bytes_cut), dir.c_str(),
                    folder->journal_problem.c_str());
      // Only a running job's count is stored (a queued one has none); on a fleet host, a
      // job interrupted while it was away gets the frames its folder lists.
      if (job.state == JobState::kRunning)
        if (Status s = store.progress(job.id, r.frames, job.frames_total, job.frames_discarded); !s)
          return s.error();
      if (job.state == JobState::kInterrupted && store.fleet())
        if (Status s = store.fleet()->set_recovered_frames(job.id, r.frames); !s) return s.error();
    } else {
      auto removed = remove_atomic_write_temporaries(dir);
      if (!removed) {
        log_warning(log::Category::kJobs, "job %lld: %s", static_cast<long long>(job.id),
                    removed.error().message.c_str());
        continue;
      }
      r.files_removed = static_cast<int>(removed->size());
    }
    if (r.files_removed > 0 || r.frames != r.frames_in_database)
      log_info(log::Category::kJobs,
               "job %lld: folder recovered: %d frames listed (the database said %d), %d "
               "unlisted or temporary files removed",
               static_cast<long long>(job.id), r.frames, r.frames_in_database, r.files_removed);
    recovered.push_back(r);
  }
  return recovered;
}

}  // namespace camlab::service
