// The daemon's own request and response values, independent of Beast: the session
// (service/http/http_session.h) converts to and from them, so that routes, handlers and their
// tests compile without the HTTP library.
//
// Reentrant: plain values. A Reply is called exactly once, from any thread.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
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

// A body produced over time (a live view's multipart JPEG stream, server-sent events):
// the session writes the head, then asks for one piece at a time and writes it, until the
// stream ends or the client goes away. The connection closes after it (the body ends with
// the connection: no length is known in advance).
class BodyStream {
 public:
  // Delivers the next piece, or nullopt: the stream has ended. Called exactly once per
  // next(), from any thread (the session posts the piece to its strand).
  using Deliver = std::function<void(std::optional<std::string>)>;
  virtual ~BodyStream() = default;
  // Called on the session's strand once the previous piece is written.
  virtual void next(Deliver deliver) = 0;
  // The client is gone (a write failed or timed out): release what the stream holds; a
  // pending next() need not deliver. Called once, on the strand.
  virtual void close() = 0;
};

struct ApiResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra headers (Allow, ...)
  // When set, `body` is ignored and the stream is the body (see BodyStream).
  std::shared_ptr<BodyStream> stream;
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

// "invalid_request" naming the first field of `body` that is not in `known` (a typo such as
// "inner_corner" would otherwise be ignored, and the request run without it), and the
// fields that are.
Status check_known_fields(const nlohmann::json& body, std::initializer_list<const char*> known);

// "state=running&limit=10": at most 16 pairs, later ones ignored; values are taken as
// they are (query parameters are numbers and words, never percent-encoded text).
using QueryParams = std::map<std::string, std::string>;
QueryParams parse_query(const std::string& query);

// A plain decimal number as a person writes one in a URL: digits with an optional
// fraction and sign ("30", "0.5", "-2", ".5"); not hexadecimal ("0x10", which strtod reads
// as 16), exponents, "inf", "nan", spaces or more than 16 characters.
std::optional<double> parse_decimal(const std::string& text);

// The number `name` from the query (parse_decimal), within [min, max]; `fallback` when
// absent. Errors "invalid_request" naming the parameter and the range.
Result<double> query_number(const QueryParams& query, const std::string& name, double min,
                            double max, double fallback);
// A flag: 1/true/yes or 0/false/no; `fallback` when absent. Errors "invalid_request".
Result<bool> query_flag(const QueryParams& query, const std::string& name, bool fallback);

// Parses a non-negative decimal integer path parameter of at most `max_digits` digits
// ("0042" is accepted, "+1", "1e3", "-1", "" and overflow are not).
Result<int64_t> parse_id(const std::string& text, const std::string& what, int max_digits = 15);

}  // namespace camlab::service
