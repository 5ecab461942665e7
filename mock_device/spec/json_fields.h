// Reading spec files: every field is looked up by a dotted path so that an error says
// exactly which field is wrong, what it was and what is allowed
// ("camera.sensor.pixel_pitch_um = -3 is out of range (0, 100]").
//
// Reentrant.
#pragma once

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/atomic_file.h"
#include "base/result.h"

namespace camlab::mock {

class JsonFields {
 public:
  JsonFields(const nlohmann::json& object, std::string path)
      : object_(object), path_(std::move(path)) {}

  bool has(const char* key) const { return object_.is_object() && object_.contains(key); }
  std::string path_of(const char* key) const { return path_ + "." + key; }
  JsonFields child(const char* key) const {
    static const nlohmann::json kEmpty = nlohmann::json::object();
    return JsonFields(has(key) ? object_.at(key) : kEmpty, path_of(key));
  }
  const nlohmann::json& json() const { return object_; }
  const std::string& path() const { return path_; }

  // A finite number in [min, max] (min_exclusive makes the lower bound open).
  Result<double> number(const char* key, double min, double max,
                        std::optional<double> fallback = std::nullopt,
                        bool min_exclusive = false) const {
    if (!has(key)) {
      if (fallback) return *fallback;
      return make_error("invalid_argument", path_of(key) + " is required");
    }
    const auto& value = object_.at(key);
    if (!value.is_number())
      return make_error("invalid_argument",
                        path_of(key) + " must be a number, not " + value.dump());
    const double x = value.get<double>();
    if (!std::isfinite(x) || x > max || (min_exclusive ? x <= min : x < min))
      return make_error("out_of_range", path_of(key) + " = " + value.dump() + " is out of range " +
                                            (min_exclusive ? "(" : "[") + trim(min) + ", " +
                                            trim(max) + "]");
    return x;
  }

  Result<int> integer(const char* key, int min, int max,
                      std::optional<int> fallback = std::nullopt) const {
    if (!has(key)) {
      if (fallback) return *fallback;
      return make_error("invalid_argument", path_of(key) + " is required");
    }
    const auto& value = object_.at(key);
    if (!value.is_number_integer())
      return make_error("invalid_argument",
                        path_of(key) + " must be an integer, not " + value.dump());
    const auto x = value.get<long long>();
    if (x < min || x > max)
      return make_error("out_of_range", path_of(key) + " = " + value.dump() + " is out of range [" +
                                            std::to_string(min) + ", " + std::to_string(max) + "]");
    return static_cast<int>(x);
  }

  Result<bool> boolean(const char* key, bool fallback) const {
    if (!has(key)) return fallback;
    const auto& value = object_.at(key);
    if (!value.is_boolean())
      return make_error("invalid_argument",
                        path_of(key) + " must be true or false, not " + value.dump());
    return value.get<bool>();
  }

  Result<std::string> string(const char* key,
                             std::optional<std::string> fallback = std::nullopt) const {
    if (!has(key)) {
      if (fallback) return *fallback;
      return make_error("invalid_argument", path_of(key) + " is required");
    }
    const auto& value = object_.at(key);
    if (!value.is_string())
      return make_error("invalid_argument",
                        path_of(key) + " must be a string, not " + value.dump());
    return value.get<std::string>();
  }

  // An array of finite numbers, each in [min, max], of length in [min_size, max_size].
  Result<std::vector<double>> numbers(const char* key, size_t min_size, size_t max_size,
                                      double min = -1e300, double max = 1e300) const {
    if (!has(key)) return make_error("invalid_argument", path_of(key) + " is required");
    const auto& value = object_.at(key);
    if (!value.is_array() || value.size() < min_size || value.size() > max_size)
      return make_error(
          "invalid_argument",
          path_of(key) + " must be an array of " +
              (min_size == max_size ? std::to_string(min_size)
                                    : std::to_string(min_size) + ".." + std::to_string(max_size)) +
              " numbers");
    std::vector<double> out;
    for (size_t i = 0; i < value.size(); ++i) {
      if (!value[i].is_number() || !std::isfinite(value[i].get<double>()) ||
          value[i].get<double>() < min || value[i].get<double>() > max)
        return make_error("out_of_range", path_of(key) + "[" + std::to_string(i) +
                                              "] = " + value[i].dump() + " must be a number in [" +
                                              trim(min) + ", " + trim(max) + "]");
      out.push_back(value[i].get<double>());
    }
    return out;
  }

 private:
  static std::string trim(double x) {
    if (x >= 1e300) return "inf";
    if (x <= -1e300) return "-inf";
    std::string s = std::to_string(x);
    while (s.size() > 1 && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  }

  const nlohmann::json& object_;
  std::string path_;
};

// Reads a JSON spec file (comments allowed); errors name the path.
inline Result<nlohmann::json> read_json_file(const std::filesystem::path& path) {
  auto text = read_text_file(path);
  if (!text) return text.error();
  nlohmann::json json = nlohmann::json::parse(*text, nullptr, false, /*ignore_comments=*/true);
  if (json.is_discarded()) return make_error("bad_json", path.string() + " is not valid JSON");
  return json;
}

}  // namespace camlab::mock
