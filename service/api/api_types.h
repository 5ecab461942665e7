// The daemon's own request and response values, independent of Beast: the session
// (service/http/http_session.h) converts to and from them, so that routes, handlers and their
// tests compile without the HTTP library.
//
// Reentrant: plain values. A Reply is called exactly once, from any thread.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::service {

struct ApiRequest {
  std::string method;  // "GET", "PUT", ...
  std::string path;    // the target before '?', still percent-encoded
  std::string query;   // after '?', without it
  std::string body;
  std::string authorization;  // the Authorization header, as sent
  std::string content_type;
  std::string remote;  // peer address, for the log
};

struct ApiResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra headers (Allow, ...)
};

// Delivers the response for one request; the session posts it to its own strand.
using Reply = std::function<void(ApiResponse)>;

// Path parameters by name ({id} -> "42"), percent-decoded.
using PathParams = std::map<std::string, std::string>;

ApiResponse json_response(int status, const nlohmann::json& body);

// {"error": {"code": code, "message": message}} with the code's HTTP status: every
// error, the library's and the handlers' own, maps through base/error_code.h at the
// handler boundary.
ApiResponse error_response(const Error& error);
ApiResponse error_response(ErrorCodeName code, const std::string& message);

// Parses a JSON request body: an object, or the error "bad_json"/"invalid_request".
Result<nlohmann::json> parse_json_object(const std::string& body);

// Parses a non-negative decimal integer path parameter of at most `max_digits` digits
// ("0042" is accepted, "+1", "1e3", "-1", "" and overflow are not).
Result<int64_t> parse_id(const std::string& text, const std::string& what, int max_digits = 15);

}  // namespace camlab::service
