#include "service/metrics.h"

#include <sstream>

namespace camlab::service {

std::string prometheus_label(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '"')
      out += "\\\"";
    else if (c == '\n')
      out += "\\n";
    else
      out.push_back(c);
  }
  return out;
}

void Metrics::count_request(const std::string& method, const std::string& route, int status) {
  std::lock_guard lock(mutex_);
  ++requests_[{method, route, status}];
}

void Metrics::count_frames(int64_t captured, int64_t discarded) {
  std::lock_guard lock(mutex_);
  frames_captured_ += captured;
  frames_discarded_ += discarded;
}

void Metrics::count_job_finished(const std::string& kind, const std::string& state) {
  std::lock_guard lock(mutex_);
  ++jobs_finished_[{kind, state}];
}

std::string Metrics::render(const std::map<std::string, int64_t>& jobs_by_state) const {
  std::lock_guard lock(mutex_);
  std::ostringstream out;
  out << "# HELP camlabd_http_requests_total HTTP requests answered, by method, route pattern and "
         "status.\n"
         "# TYPE camlabd_http_requests_total counter\n";
  for (const auto& [key, count] : requests_) {
    const auto& [method, route, status] = key;
    out << "camlabd_http_requests_total{method=\"" << prometheus_label(method) << "\",route=\""
        << prometheus_label(route) << "\",status=\"" << status << "\"} " << count << "\n";
  }
  out << "# HELP camlabd_jobs Jobs in the database, by state.\n# TYPE camlabd_jobs gauge\n";
  for (const char* state :
       {"queued", "running", "succeeded", "failed", "cancelled", "interrupted", "device_lost"}) {
    auto it = jobs_by_state.find(state);
    out << "camlabd_jobs{state=\"" << state << "\"} "
        << (it == jobs_by_state.end() ? 0 : it->second) << "\n";
  }
  out << "# HELP camlabd_jobs_finished_total Jobs finished since start, by kind and final state.\n"
         "# TYPE camlabd_jobs_finished_total counter\n";
  for (const auto& [key, count] : jobs_finished_)
    out << "camlabd_jobs_finished_total{kind=\"" << prometheus_label(key.first) << "\",state=\""
        << prometheus_label(key.second) << "\"} " << count << "\n";
  out << "# HELP camlabd_frames_captured_total Frames kept and written by captures since start.\n"
         "# TYPE camlabd_frames_captured_total counter\n"
      << "camlabd_frames_captured_total " << frames_captured_ << "\n"
      << "# HELP camlabd_frames_discarded_total Frames discarded while new settings settled, since "
         "start.\n"
         "# TYPE camlabd_frames_discarded_total counter\n"
      << "camlabd_frames_discarded_total " << frames_discarded_ << "\n";
  return out.str();
}

}  // namespace camlab::service
