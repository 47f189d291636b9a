// The bearer token as the client writes it and the server reads it, both
// from wire/bearer_token.h: whatever token the client may send is read back
// as itself, and one the server must refuse is refused naming why. (The full
// table of headers, as both frontends read them, is exposure_test.cpp's.)
#include "wire/bearer_token.h"

#include <gtest/gtest.h>

#include <string>

namespace mm::wire {
namespace {

TEST(BearerToken, WrittenTokenIsReadBackAsItself) {
  std::string every_visible_byte;
  for (char c = 0x21; c < 0x7f; ++c) every_visible_byte += c;
  for (const std::string& token : {std::string("exposure-test-token-7f3a"), std::string("a"), every_visible_byte,
                                   std::string(kMaxBearerTokenBytes, 'x')}) {
    const std::string header = bearer_authorization(token);
    EXPECT_EQ(header, "Bearer " + token);
    const BearerCredentials read = parse_authorization({header});
    EXPECT_EQ(read.token, token);
    EXPECT_EQ(read.problem, "");
  }
}

TEST(BearerToken, NoHeaderOrBlankHeaderIsNoToken) {
  for (const auto& headers : {std::vector<std::string>{}, std::vector<std::string>{" \t "}}) {
    const BearerCredentials read = parse_authorization(headers);
    EXPECT_EQ(read.token, "");
    EXPECT_EQ(read.problem, "");
  }
}

TEST(BearerToken, TokenTheServerRefusesIsNamedWithWhy) {
  struct Case {
    std::string token;
    std::string problem;
  };
  const Case cases[] = {
      {"ab cd", "a space or a control or non-ASCII byte at position 2"},
      {std::string("abc\x01", 4), "a space or a control or non-ASCII byte at position 3"},
      {"caf\xc3\xa9", "a space or a control or non-ASCII byte at position 3"},
      {std::string(kMaxBearerTokenBytes + 1, 'x'), "longer than 4096 bytes"},
      {"", "has the Bearer scheme but no token"},
  };
  for (const auto& c : cases) {
    const BearerCredentials read = parse_authorization({bearer_authorization(c.token)});
    EXPECT_EQ(read.token, "") << c.token.substr(0, 40);
    EXPECT_NE(read.problem.find(c.problem), std::string::npos) << c.token.substr(0, 40) << ": " << read.problem;
  }
}

TEST(BearerToken, AnotherSchemeIsNamedWithoutWhatFollowsIt) {
  const BearerCredentials read = parse_authorization({"Basic dXNlcjpzZWNyZXQ="});
  EXPECT_EQ(read.token, "");
  EXPECT_EQ(read.problem, "expected the Bearer scheme (Authorization: Bearer <token>), found \"Basic\"");
}

}  // namespace
}  // namespace mm::wire
