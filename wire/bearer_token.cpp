#include "wire/bearer_token.h"

#include <cctype>

namespace mm::wire {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

const char kBearerWithoutToken[] = "the Authorization header has the Bearer scheme but no token";

std::string bearer_authorization(const std::string& token) { return "Bearer " + token; }

BearerCredentials parse_authorization(const std::vector<std::string>& header_values) {
  // A blank header is no header: HTTP clients drop empty header fields, gRPC
  // sends them, and both frontends must read a call alike.
  std::vector<const std::string*> present;
  for (const auto& value : header_values) {
    if (value.find_first_not_of(" \t") != std::string::npos) present.push_back(&value);
  }
  if (present.empty()) return {};
  if (present.size() > 1) {
    return {"", "expected one Authorization header, found " + std::to_string(present.size())};
  }
  const std::string& value = *present.front();
  size_t begin = 0, end = value.size();
  while (begin < end && is_blank(value[begin])) ++begin;
  while (end > begin && is_blank(value[end - 1])) --end;
  size_t scheme_end = begin;
  while (scheme_end < end && !is_blank(value[scheme_end])) ++scheme_end;
  const std::string scheme = value.substr(begin, scheme_end - begin);
  if (lowercase(scheme) != "bearer") {
    // The scheme only: what follows it may be a password.
    return {"", "expected the Bearer scheme (Authorization: Bearer <token>), found \"" + scheme.substr(0, 32) + "\""};
  }
  size_t token_begin = scheme_end;
  while (token_begin < end && is_blank(value[token_begin])) ++token_begin;
  if (token_begin == end) return {"", kBearerWithoutToken};
  if (end - token_begin > kMaxBearerTokenBytes) {
    return {"", "the bearer token is longer than " + std::to_string(kMaxBearerTokenBytes) + " bytes"};
  }
  for (size_t i = token_begin; i < end; ++i) {
    const auto c = static_cast<unsigned char>(value[i]);
    if (c <= 0x20 || c >= 0x7f) {
      return {"", "the bearer token holds a space or a control or non-ASCII byte at position " +
                      std::to_string(i - token_begin)};
    }
  }
  return {value.substr(token_begin, end - token_begin), ""};
}

}  // namespace mm::wire
