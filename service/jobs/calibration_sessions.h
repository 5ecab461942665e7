// The daemon's guided calibration sessions (POST /v1/calibration-sessions): each is a job
// record of kind "calibration_session" (so it is listed with the jobs, and a restart
// ends it interrupted) whose live state this manager keeps in memory.
//
// Taking a view queues an ordinary capture job ({"kind": "single"}) on the session's
// camera, so the frame is stored with its settings like any other; the manager's one
// thread waits for it, detects the board in the frame, solves (warm-started), computes the
// uncertainty over the imager and the next suggested view (calibration_session.h), and
// publishes the session's new state. Finishing runs the full calibration on the session's
// corners into DATA/calibrations/session-NNNNNN/ (camera.cameramodel, report.json,
// corners.vnl). One thread: sessions are interactive and a view costs well under a
// second of CPU; the cameras' and the HTTP threads are never held by it.
//
// Bounds: at most `max_live_sessions` open at once (too_many_jobs beyond); one view or
// finish in progress per session (conflict otherwise); a capture that does not finish
// within `capture_timeout` ends the view with an error.
//
// Thread-safe: every public member, from any thread.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::service {

class CameraSet;
class CalibrationSession;
class JobStore;

class CalibrationSessions {
 public:
  CalibrationSessions(std::filesystem::path data_dir, JobStore& store, CameraSet& cameras,
                      int max_live_sessions = 4,
                      std::chrono::milliseconds capture_timeout = std::chrono::seconds(60));
  ~CalibrationSessions();
  CalibrationSessions(const CalibrationSessions&) = delete;
  CalibrationSessions& operator=(const CalibrationSessions&) = delete;

  void start();
  void stop();  // ends open sessions interrupted; waits for the view in progress

  // Opens a session on `camera_id` for a normalised calibration request
  // (calibration_request.h) plus "target_uncertainty_px". Returns its state.
  // Errors: "not_found" (camera), "no_device", "too_many_jobs", "shutting_down".
  Result<nlohmann::json> open(const std::string& camera_id, const nlohmann::json& request);
  // The state of session `id`: live, or from its job record once ended.
  // Error "not_found".
  Result<nlohmann::json> state(int64_t id);
  // Queues a capture on the session's camera and a view on the session thread; returns
  // the state ("phase": "capturing"). Errors: "not_found", "conflict" (a view or finish in
  // progress, or the session ended), those of the camera's queue.
  Result<nlohmann::json> take_view(int64_t id);
  // Queues the finish; the state then shows "finishing" and, once done, the job record
  // holds the report ("succeeded") or the error ("failed").
  Result<nlohmann::json> finish(int64_t id);
  // Ends the session cancelled (a capture already queued for it still runs).
  Result<nlohmann::json> cancel(int64_t id);

 private:
  struct Live;
  enum class Work { kView, kFinish };
  void run();
  void do_view(const std::shared_ptr<Live>& live, int64_t capture_job);
  void do_finish(const std::shared_ptr<Live>& live);
  nlohmann::json state_json(const Live& live) const;  // mutex_ held
  std::shared_ptr<Live> find_live(int64_t id);        // mutex_ held
  // The error for a session that is not live: conflict (ended) or not_found. Reads only
  // the store, so callers may hold mutex_.
  Error not_live(int64_t id);

  const std::filesystem::path data_dir_;
  JobStore& store_;
  CameraSet& cameras_;
  const int max_live_sessions_;
  const std::chrono::milliseconds capture_timeout_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::map<int64_t, std::shared_ptr<Live>> live_;
  struct Pending {
    int64_t session = 0;
    Work work = Work::kView;
    int64_t capture_job = 0;
  };
  std::deque<Pending> pending_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace camlab::service
