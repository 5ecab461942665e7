#include "service/api/api_types.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include "base/format.h"

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

Status check_known_fields(const nlohmann::json& body, std::initializer_list<const char*> known) {
  for (const auto& [key, value] : body.items()) {
    bool found = false;
    for (const char* k : known) found |= key == k;
    if (found) continue;
    std::string list;
    for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
    return make_error("invalid_request",
                      "unknown field '" + key.substr(0, 40) + "' (" + list + ")");
  }
  return {};
}

QueryParams parse_query(const std::string& query) {
  QueryParams out;
  size_t start = 0;
  while (start < query.size() && out.size() < 16) {
    size_t end = query.find('&', start);
    if (end == std::string::npos) end = query.size();
    const std::string pair = query.substr(start, end - start);
    const size_t eq = pair.find('=');
    out[pair.substr(0, eq)] = eq == std::string::npos ? "" : pair.substr(eq + 1);
    start = end + 1;
  }
  return out;
}

std::optional<double> parse_decimal(const std::string& text) {
  if (text.empty() || text.size() > 16) return std::nullopt;
  const size_t start = text[0] == '-' || text[0] == '+' ? 1 : 0;
  int digits = 0, dots = 0;
  for (size_t k = start; k < text.size(); ++k) {
    if (std::isdigit(static_cast<unsigned char>(text[k])))
      ++digits;
    else if (text[k] == '.' && ++dots == 1)
      continue;
    else
      return std::nullopt;
  }
  if (digits == 0) return std::nullopt;
  // Only digits, one point and a sign are left: strtod reads them as written.
  return std::strtod(text.c_str(), nullptr);
}

Result<double> query_number(const QueryParams& query, const std::string& name, double min,
                            double max, double fallback) {
  auto it = query.find(name);
  if (it == query.end()) return fallback;
  const std::optional<double> parsed = parse_decimal(it->second);
  const double value = parsed.value_or(NAN);
  if (!parsed || !(value >= min) || value > max)
    return make_error("invalid_request", name + " must be a number in [" + format_significant(min) +
                                             ", " + format_significant(max) + "], not '" +
                                             it->second.substr(0, 16) + "'");
  return value;
}

Result<bool> query_flag(const QueryParams& query, const std::string& name, bool fallback) {
  auto it = query.find(name);
  if (it == query.end()) return fallback;
  if (it->second == "1" || it->second == "true" || it->second == "yes" || it->second.empty())
    return true;
  if (it->second == "0" || it->second == "false" || it->second == "no") return false;
  return make_error("invalid_request", name + " must be 1 or 0 (true or false), not '" +
                                           it->second.substr(0, 16) + "'");
}

}  // namespace camlab::service
