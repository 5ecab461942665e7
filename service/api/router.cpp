#include "service/api/router.h"

#include <atomic>
#include <exception>
#include <memory>

#include "base/log.h"
#include "service/api/auth.h"
#include "service/metrics.h"

namespace camlab::service {

namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Matches decoded segments against a pattern; fills `params` on success.
bool match(const std::vector<std::string>& pattern, const std::vector<std::string>& segments,
           PathParams* params) {
  if (pattern.size() != segments.size()) return false;
  PathParams found;
  for (size_t i = 0; i < pattern.size(); ++i) {
    const std::string& p = pattern[i];
    if (p.size() > 2 && p.front() == '{' && p.back() == '}') {
      if (segments[i].empty()) return false;
      found[p.substr(1, p.size() - 2)] = segments[i];
    } else if (p != segments[i]) {
      return false;
    }
  }
  *params = std::move(found);
  return true;
}

}  // namespace

bool percent_decode_segment(const std::string& in, std::string* out) {
  out->clear();
  for (size_t i = 0; i < in.size(); ++i) {
    char c = in[i];
    if (c == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = hex_value(in[i + 1]), lo = hex_value(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      c = static_cast<char>(hi * 16 + lo);
      i += 2;
    }
    if (c == '/' || c == '\0') return false;
    out->push_back(c);
  }
  return true;
}

std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> segments;
  size_t start = path.empty() || path[0] != '/' ? 0 : 1;
  while (start <= path.size()) {
    const size_t end = path.find('/', start);
    const std::string segment =
        path.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (end == std::string::npos) {
      if (!segment.empty()) segments.push_back(segment);
      break;
    }
    segments.push_back(segment);
    start = end + 1;
  }
  return segments;
}

void Router::add(Route route) { routes_.push_back(std::move(route)); }

bool Router::wrap(const std::string& method, const std::string& pattern, Wrapper wrapper) {
  for (Route& route : routes_) {
    if (route.method != method || route.pattern != pattern) continue;
    route.handler = [next = std::move(route.handler), wrapper = std::move(wrapper)](
                        const ApiRequest& request, const PathParams& params, Reply reply) {
      wrapper(request, params, std::move(reply), next);
    };
    return true;
  }
  return false;
}

void Router::hide_data_dir(const std::filesystem::path& data_dir) {
  hidden_prefix_ = (data_dir / "").string();
}

void Router::dispatch(const ApiRequest& request, Reply reply) const {
  // Every answer is counted once, under the route's pattern (bounded label set).
  auto counted = [this, method = request.method,
                  reply = std::move(reply)](const std::string& route_label) {
    return [this, method, route_label, reply](ApiResponse response) {
      if (metrics_) metrics_->count_request(method, route_label, response.status);
      // JSON only: image bytes are never rewritten.
      if (!hidden_prefix_.empty() && response.content_type.rfind("application/json", 0) == 0)
        for (size_t at = response.body.find(hidden_prefix_); at != std::string::npos;
             at = response.body.find(hidden_prefix_, at))
          response.body.erase(at, hidden_prefix_.size());
      reply(std::move(response));
    };
  };

  std::vector<std::string> segments;
  for (const std::string& raw : split_path(request.path)) {
    std::string decoded;
    if (!percent_decode_segment(raw, &decoded)) {
      counted("unmatched")(
          error_response("invalid_request", "malformed percent-encoding in the path"));
      return;
    }
    segments.push_back(std::move(decoded));
  }

  const Route* found = nullptr;
  PathParams params;
  std::string allowed;
  for (const Route& route : routes_) {
    PathParams candidate;
    if (!match(split_path(route.pattern), segments, &candidate)) continue;
    if (route.method == request.method || (request.method == "HEAD" && route.method == "GET")) {
      found = &route;
      params = std::move(candidate);
      break;
    }
    allowed += (allowed.empty() ? "" : ", ") + route.method;
  }

  const bool is_public = found && found->is_public;
  if (!is_public && auth_ && !auth_->accepts(request.authorization)) {
    ApiResponse response =
        error_response("unauthorized",
                       "send the API token as 'Authorization: Bearer TOKEN' (it is in "
                       "the data folder's 'token' file)");
    response.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"camlabd\"");
    counted(found ? found->pattern : "unmatched")(std::move(response));
    return;
  }
  if (!found) {
    if (!allowed.empty()) {
      ApiResponse response = error_response(
          "method_not_allowed", request.method + " is not allowed here; allowed: " + allowed);
      response.headers.emplace_back("Allow", allowed);
      counted("unmatched")(std::move(response));
    } else {
      counted("unmatched")(error_response("no_route", "no endpoint " + request.method + " " +
                                                          request.path.substr(0, 200) +
                                                          " (GET /v1/openapi.json lists them)"));
    }
    return;
  }
  // Exactly one answer per request, even if a handler throws after replying: a bug in
  // one handler must cost one request a 500, not the daemon.
  auto answered = std::make_shared<std::atomic<bool>>(false);
  Reply once = [answered, reply = counted(found->pattern)](ApiResponse response) {
    if (!answered->exchange(true)) reply(std::move(response));
  };
  try {
    found->handler(request, params, once);
  } catch (const std::exception& e) {
    log_error(log::Category::kHttp, "%s %s: unexpected exception: %s", request.method.c_str(),
              found->pattern.c_str(), e.what());
    once(error_response("internal", "the request failed unexpectedly; see the daemon's log"));
  }
}

}  // namespace camlab::service
