// The handler boundary (service/api/api_types.h): every error code of the library maps to
// its HTTP status and JSON body, and request bodies and ids are checked before use.
#include "service/api/api_types.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace camlab::service {
namespace {

TEST(ApiTypes, EveryErrorCodeMapsToItsStatusAndBody) {
  for (const ErrorCodeInfo& info : kErrorCodes) {
    const ApiResponse response = error_response(make_error(info.code, "what went wrong"));
    EXPECT_EQ(response.status, info.http_status) << info.name;
    EXPECT_GE(response.status, 400) << info.name << " must not answer as a success";
    EXPECT_EQ(response.content_type, "application/json");
    const auto body = nlohmann::json::parse(response.body);
    EXPECT_EQ(body["error"]["code"], info.name);
    EXPECT_EQ(body["error"]["message"], "what went wrong");
  }
}

TEST(ApiTypes, TheStatusesClientsRelyOn) {
  // The statuses docs/service.md documents; a change here breaks clients.
  EXPECT_EQ(error_response("invalid_request", "x").status, 400);
  EXPECT_EQ(error_response("bad_json", "x").status, 400);
  EXPECT_EQ(error_response("unauthorized", "x").status, 401);
  EXPECT_EQ(error_response("not_found", "x").status, 404);
  EXPECT_EQ(error_response("no_route", "x").status, 404);
  EXPECT_EQ(error_response("method_not_allowed", "x").status, 405);
  EXPECT_EQ(error_response("busy", "x").status, 409);
  EXPECT_EQ(error_response("payload_too_large", "x").status, 413);
  EXPECT_EQ(error_response("out_of_range", "x").status, 422);
  EXPECT_EQ(error_response("invalid_argument", "x").status, 422);
  EXPECT_EQ(error_response("too_many_jobs", "x").status, 429);
  EXPECT_EQ(error_response("headers_too_large", "x").status, 431);
  EXPECT_EQ(error_response("io_error", "x").status, 500);
  EXPECT_EQ(error_response("internal", "x").status, 500);
  EXPECT_EQ(error_response("no_device", "x").status, 503);
  EXPECT_EQ(error_response("timeout", "x").status, 504);
}

TEST(ApiTypes, RequestBodiesMustBeJsonObjects) {
  EXPECT_TRUE(parse_json_object(R"({"kind": "single"})").ok());
  const auto broken = parse_json_object("{\"kind\": ");
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.error().code, ErrorCode::kBadJson);
  const auto array = parse_json_object("[1, 2]");
  ASSERT_FALSE(array.ok());
  EXPECT_EQ(array.error().code, ErrorCode::kInvalidRequest);
}

TEST(ApiTypes, IdsAreBoundedDecimalNumbers) {
  EXPECT_EQ(*parse_id("0042", "job id"), 42);
  for (const char* bad : {"", "+1", "-1", "1e3", "12a", "1234567890123456"}) {
    const auto id = parse_id(bad, "job id");
    ASSERT_FALSE(id.ok()) << bad;
    EXPECT_EQ(id.error().code, ErrorCode::kInvalidRequest) << bad;
    EXPECT_NE(id.error().message.find("job id"), std::string::npos) << id.error().message;
  }
}

TEST(ApiTypes, QueryNumbersAreDecimalOnly) {
  EXPECT_EQ(*parse_decimal("30"), 30);
  EXPECT_EQ(*parse_decimal("0.5"), 0.5);
  EXPECT_EQ(*parse_decimal(".5"), 0.5);
  EXPECT_EQ(*parse_decimal("-2"), -2);
  // strtod reads "0x10" as 16 s of wait and "1e1" as 10: not numbers a URL means.
  for (const char* bad : {"", "0x10", "0X1p4", "1e1", "inf", "nan", " 5", "5 ", "1.2.3", ".", "-",
                          "12345678901234567"})
    EXPECT_FALSE(parse_decimal(bad).has_value()) << bad;
  const auto hex = query_number(parse_query("wait=0x10"), "wait", 0, 60, 0);
  ASSERT_FALSE(hex.ok());
  EXPECT_EQ(hex.error().code, ErrorCode::kInvalidRequest);
  EXPECT_EQ(*query_number(parse_query("wait=12.5"), "wait", 0, 60, 0), 12.5);
}

}  // namespace
}  // namespace camlab::service
