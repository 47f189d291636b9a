#include "format/json_text.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/input_error.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(JsonText, ParsesAnyDocumentAndLeavesItsShapeToTheCaller) {
  EXPECT_EQ(parse_json_text(R"({"a": [1, 2]})", "x.json")["a"][1], 2);
  EXPECT_TRUE(parse_json_text("3", "x.json").is_number());
}

TEST(JsonText, SyntaxErrorNamesTheSourceAndWhereItBroke) {
  try {
    parse_json_text("{\"a\": 1,", "models/m/manifest.json");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), StartsWith("models/m/manifest.json: not valid JSON: "));
    EXPECT_THAT(e.what(), HasSubstr("line 1"));
  }
  EXPECT_THROW(parse_json_text("", "empty.json"), InputError);
}

}  // namespace
}  // namespace mm
