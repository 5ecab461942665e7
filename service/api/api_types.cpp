#include "service/api/api_types.h"

#include <cctype>
#include <set>
#include <string>
#include <vector>

namespace camlab::service {

ApiResponse json_response(int status, const nlohmann::json& body) {
  ApiResponse response;
  response.status = status;
  // Replace invalid UTF-8 (from a device name, say) instead of throwing while serving.
  response.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return response;
}

ApiResponse error_response(const Error& error) {
  return json_response(info_of(error.code).http_status,
                       {{"error", {{"code", name_of(error.code)}, {"message", error.message}}}});
}

ApiResponse error_response(ErrorCodeName code, const std::string& message) {
  return error_response(make_error(code, message));
}

Result<nlohmann::json> parse_json_object(const std::string& body) {
  // RFC 8259 8.1: a sender must not add a byte order mark; the parser would skip it.
  if (body.rfind("\xEF\xBB\xBF", 0) == 0)
    return make_error("bad_json", "the request body starts with a UTF-8 byte order mark");
  // Duplicate keys: the parser keeps the last, so {"repeats": 1, "repeats": 1000} would run
  // what the client did not mean to send. One set of keys per open object.
  std::vector<std::set<std::string>> keys_per_object;
  std::string duplicate;
  const nlohmann::json::parser_callback_t check_keys = [&](int, nlohmann::json::parse_event_t event,
                                                           nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) keys_per_object.emplace_back();
    if (event == Event::object_end && !keys_per_object.empty()) keys_per_object.pop_back();
    if (event == Event::key && !keys_per_object.empty() && duplicate.empty() &&
        !keys_per_object.back().insert(parsed.get<std::string>()).second)
      duplicate = parsed.get<std::string>();
    return true;
  };
  nlohmann::json json = nlohmann::json::parse(body, check_keys, /*allow_exceptions=*/false);
  if (json.is_discarded()) return make_error("bad_json", "the request body is not valid JSON");
  if (!duplicate.empty())
    return make_error("bad_json", "the request body has the key \"" + duplicate.substr(0, 100) +
                                      "\" twice in one object");
  if (!json.is_object())
    return make_error("invalid_request", "the request body must be a JSON object");
  return json;
}

Result<int64_t> parse_id(const std::string& text, const std::string& what, int max_digits) {
  if (text.empty() || static_cast<int>(text.size()) > max_digits)
    return make_error("invalid_request", what + " must be a decimal number of 1 to " +
                                             std::to_string(max_digits) + " digits, not '" +
                                             text.substr(0, 32) + "'");
  int64_t value = 0;
  for (char c : text) {
    if (!std::isdigit(static_cast<unsigned char>(c)))
      return make_error("invalid_request",
                        what + " must be a decimal number, not '" + text.substr(0, 32) + "'");
    value = value * 10 + (c - '0');
  }
  return value;
}

}  // namespace camlab::service
