// The route table: method + path pattern ("/v1/jobs/{id}/frames/{n}") -> handler.
// Dispatch splits the path into segments, percent-decodes each, matches the patterns in
// order, checks the bearer token (every route but the public ones), and wraps the reply
// to count the request in the metrics by route pattern and status.
//
// Routes are added before serving starts; dispatch is then thread-safe (read-only).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "service/api/api_types.h"

namespace camlab::service {

class Metrics;
class TokenAuth;

using Handler = std::function<void(const ApiRequest&, const PathParams&, Reply)>;

struct Route {
  std::string method;   // "GET", "POST", "PUT", "DELETE"
  std::string pattern;  // literal segments and {name} parameters
  std::string summary;  // one line, for the OpenAPI document
  Handler handler;
  bool is_public = false;  // served without the token (only GET /v1/health)
  bool test_only = false;  // registered only with --test-faults
};

class Router {
 public:
  Router(const TokenAuth* auth, Metrics* metrics) : auth_(auth), metrics_(metrics) {}

  void add(Route route);
  // Puts `wrapper` around the handler of the route `method` `pattern` added before: the
  // wrapper answers itself or passes the request on to the handler it is given (a fleet
  // host answers for the cameras and jobs of other hosts, service/api/api_fleet.cpp).
  // False when there is no such route.
  using Wrapper =
      std::function<void(const ApiRequest&, const PathParams&, Reply, const Handler& next)>;
  bool wrap(const std::string& method, const std::string& pattern, Wrapper wrapper);
  const std::vector<Route>& routes() const { return routes_; }

  // The data folder's absolute path, hidden from JSON answers: error messages name files
  // relative to it ("captures/job-000001/frame_000000.png"), so that a client learns
  // nothing of the server's file system.
  void hide_data_dir(const std::filesystem::path& data_dir);

  // Answers through `reply` exactly once: 401 without a valid token, 404 for an unknown
  // path, 405 (with Allow) for a known path and another method, else the handler's.
  void dispatch(const ApiRequest& request, Reply reply) const;

 private:
  const TokenAuth* auth_;
  Metrics* metrics_;
  std::vector<Route> routes_;
  std::string hidden_prefix_;  // "/abs/data/" or empty
};

// Percent-decodes one path segment; false for a malformed escape or a decoded '/' or NUL
// (which could otherwise smuggle a path separator into a parameter).
bool percent_decode_segment(const std::string& in, std::string* out);

// Splits "/a/b/c" into {"a", "b", "c"}; a trailing slash is ignored.
std::vector<std::string> split_path(const std::string& path);

}  // namespace camlab::service
