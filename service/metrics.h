// Prometheus metrics (text exposition format 0.0.4): requests by method, route pattern
// and status; frames captured and discarded; jobs by state (read from the job store when
// scraped, so it is never out of step with the database).
//
// Thread-safe: counters under one mutex (increments are rare next to a frame's cost).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>

namespace camlab::service {

class Metrics {
 public:
  void count_request(const std::string& method, const std::string& route, int status);
  void count_frames(int64_t captured, int64_t discarded);
  void count_job_finished(const std::string& kind, const std::string& state);

  // Renders every metric; `jobs_by_state` is asked for the current counts.
  std::string render(const std::map<std::string, int64_t>& jobs_by_state) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, int64_t> requests_;
  std::map<std::pair<std::string, std::string>, int64_t> jobs_finished_;
  int64_t frames_captured_ = 0;
  int64_t frames_discarded_ = 0;
};

// Escapes a label value for the text format (backslash, quote, newline).
std::string prometheus_label(const std::string& value);

}  // namespace camlab::service
