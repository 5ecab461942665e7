// What camlabd does at start for the jobs its last run left queued or running (a crash,
// kill -9, a power cut), before it marks them interrupted: the folders are the truth, and
// the database is brought into line with them.
//
// - A capture's folder is recovered (image/capture_folder_recovery.h): its journal cut to
//   whole lines, frame files it does not list and temporaries removed. The job's frame
//   count becomes the number of frames the journal lists: the database may be behind it
//   (a frame listed, the process killed before its count was stored), never ahead.
// - Any other job's folder (a calibration's) loses the temporaries of atomic writes.
//
// On a fleet host (PostgreSQL) the jobs are this host's: those it left unfinished, and
// those the fleet interrupted while it was away (killed: its lease passed meanwhile), whose
// frame count becomes what the recovered folder lists when that is more.
//
// Thread-compatible: run once at start, before any worker writes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "base/result.h"

namespace camlab::service {

class JobStore;

struct RecoveredJob {
  int64_t id = 0;
  int frames = 0;              // a capture's frames listed after recovery
  int frames_in_database = 0;  // what the database said before
  int files_removed = 0;
};

// Recovers every queued or running job's folder (and, on a fleet host, those said above);
// a folder that cannot be recovered is logged and left as it is (the job is still marked
// interrupted afterwards).
Result<std::vector<RecoveredJob>> recover_unfinished_jobs(JobStore& store,
                                                          const std::filesystem::path& data_dir);

}  // namespace camlab::service
