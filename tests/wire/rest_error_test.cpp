// The REST refusal's body as the server writes it and the client reads it,
// both from wire/rest_error.h: the code, the field and the message come back
// as they were sent, byte for byte the layout the REST contract gives.
#include "wire/rest_error.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

namespace mm::wire {
namespace {

TEST(RestError, BodyHasTheContractsLayout) {
  EXPECT_EQ(rest_error_body({"INVALID_ARGUMENT", "motions[0].columns", "expected 99 columns, found 98"}),
            R"({"error":{"code":"INVALID_ARGUMENT","field":"motions[0].columns","message":"expected 99 columns, found 98"}})");
}

TEST(RestError, WrittenRefusalIsReadBackAsItself) {
  const RestError cases[] = {
      {"INVALID_ARGUMENT", "motions[0].values[12]", "expected a number, found \"abc\""},
      {"UNAUTHENTICATED", "authorization", "the bearer token holds a space"},
      {"RESOURCE_EXHAUSTED", "", "the body is longer than 1048576 bytes"},
      {"NOT_FOUND", "model", "no model \"x\"\n\t\"quoted\" \\ slash"},
  };
  for (const auto& sent : cases) {
    const auto read = rest_error_from_body(rest_error_body(sent), "INTERNAL");
    ASSERT_TRUE(read.has_value()) << sent.message;
    EXPECT_EQ(read->code, sent.code);
    EXPECT_EQ(read->field, sent.field);
    EXPECT_EQ(read->message, sent.message);
  }
}

TEST(RestError, BytesThatAreNotUtf8AreReplacedNotRefused) {
  const auto read = rest_error_from_body(rest_error_body({"INVALID_ARGUMENT", "path", "bad byte \xff here"}), "");
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->message, "bad byte \xef\xbf\xbd here");
}

TEST(RestError, AbsentFieldsTakeTheirDefaults) {
  const auto read = rest_error_from_body(R"({"error": {"message": "m"}})", "UNAVAILABLE");
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->code, "UNAVAILABLE");
  EXPECT_EQ(read->field, "");
  EXPECT_EQ(read->message, "m");
}

TEST(RestError, BodyThatIsNotARefusalIsNone) {
  for (const char* body : {"", "<html>502 Bad Gateway</html>", "[1]", R"({"error": "text"})", R"({"models": []})"}) {
    EXPECT_FALSE(rest_error_from_body(body, "INTERNAL").has_value()) << body;
  }
}

TEST(RestError, FieldOfTheWrongTypeThrows) {
  EXPECT_THROW(rest_error_from_body(R"({"error": {"code": 3}})", "INTERNAL"), nlohmann::json::type_error);
}

}  // namespace
}  // namespace mm::wire
