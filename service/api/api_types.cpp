#include "service/api/api_types.h"

#include <cctype>

namespace camlab::service {

ApiResponse json_response(int status, const nlohmann::json& body) {
  ApiResponse response;
  response.status = status;
  // Replace invalid UTF-8 (from a device name, say) instead of throwing while serving.
  response.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return response;
}

ApiResponse error_response(int status, const std::string& code, const std::string& message) {
  return json_response(status, {{"error", {{"code", code}, {"message", message}}}});
}

int http_status_for(const std::string& code) {
  static const std::map<std::string, int> kStatus = {
      {"invalid_request", 400}, {"bad_json", 400},         {"unauthorized", 401},
      {"not_found", 404},       {"conflict", 409},         {"busy", 409},
      {"not_cancellable", 409}, {"payload_too_large", 413}, {"out_of_range", 422},
      {"unsupported", 422},     {"no_frames", 422},        {"too_many_jobs", 429},
      {"no_device", 503},       {"unavailable", 503},      {"shutting_down", 503}};
  auto it = kStatus.find(code);
  return it == kStatus.end() ? 500 : it->second;
}

ApiResponse error_response(const Error& error) {
  return error_response(http_status_for(error.code), error.code, error.message);
}

Result<nlohmann::json> parse_json_object(const std::string& body) {
  nlohmann::json json = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return make_error("bad_json", "the request body is not valid JSON");
  if (!json.is_object()) return make_error("invalid_request", "the request body must be a JSON object");
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
      return make_error("invalid_request", what + " must be a decimal number, not '" + text.substr(0, 32) + "'");
    value = value * 10 + (c - '0');
  }
  return value;
}

}  // namespace camlab::service
