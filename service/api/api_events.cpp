// GET /v1/events: job changes as server-sent events (text/event-stream), for the dashboard's
// job list and for scripts that would otherwise poll (`curl -N -H "Authorization: ..."`).
// Each change is an event "job" whose data is {"id", "state", "frames_done",
// "frames_total", "frames_discarded"}; a client that fell too far behind gets "resync"
// (read GET /v1/jobs again); a comment line every 15 s keeps the connection checked.
// Batching and limits: service/jobs/job_events.h.
#include <memory>

#include "service/api/service_context.h"
#include "service/jobs/job_events.h"

namespace camlab::service {

namespace {

std::string event_text(const JobEventBatch& batch, uint64_t* next_id) {
  if (batch.resync) return "event: resync\nid: " + std::to_string((*next_id)++) + "\ndata: {}\n\n";
  if (batch.changes.empty()) return ": keep-alive\n\n";
  std::string text;
  for (const JobChange& c : batch.changes) {
    const nlohmann::json data = {{"id", c.id},
                                 {"state", job_state_name(c.state)},
                                 {"frames_done", c.frames_done},
                                 {"frames_total", c.frames_total},
                                 {"frames_discarded", c.frames_discarded}};
    text += "event: job\nid: " + std::to_string((*next_id)++) + "\ndata: " + data.dump() + "\n\n";
  }
  return text;
}

class EventStream : public BodyStream {
 public:
  explicit EventStream(std::shared_ptr<JobEvents::Subscription> subscription)
      : subscription_(std::move(subscription)) {}
  ~EventStream() override { subscription_->close(); }
  void next(Deliver deliver) override {
    if (!greeted_) {
      // How long a browser's EventSource waits before reconnecting, and a first line so
      // the client knows at once that it is connected.
      greeted_ = true;
      return deliver(std::string("retry: 2000\n: connected\n\n"));
    }
    subscription_->next([this, deliver = std::move(deliver)](Result<JobEventBatch> batch) {
      deliver(batch ? std::optional<std::string>(event_text(*batch, &next_id_)) : std::nullopt);
    });
  }
  void close() override { subscription_->close(); }

 private:
  std::shared_ptr<JobEvents::Subscription> subscription_;
  bool greeted_ = false;
  uint64_t next_id_ = 1;  // touched on the event thread only, one delivery at a time
};

}  // namespace

void add_event_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/events",
              "Job changes as server-sent events (text/event-stream): event \"job\" with id, "
              "state and progress; \"resync\" when the client fell behind",
              [context](const ApiRequest&, const PathParams&, Reply reply) {
                if (!context.events)
                  return reply(error_response("unsupported", "this camlabd sends no events"));
                auto subscription = context.events->subscribe();
                if (!subscription) return reply(error_response(subscription.error()));
                ApiResponse response;
                response.content_type = "text/event-stream";
                // A proxy must pass events on as they come, not buffer them.
                response.headers.emplace_back("X-Accel-Buffering", "no");
                response.stream = std::make_shared<EventStream>(std::move(*subscription));
                reply(std::move(response));
              }});
}

}  // namespace camlab::service
