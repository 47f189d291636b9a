#include "core/caller_identity.h"

#include <arpa/inet.h>

#include <cctype>
#include <cstring>

namespace mm::service {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

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
  if (token_begin == end) return {"", "the Authorization header has the Bearer scheme but no token"};
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

bool tokens_equal(const std::string& given, const std::string& expected) {
  unsigned char difference = given.size() == expected.size() ? 0 : 1;
  if (expected.empty()) return false;
  for (size_t i = 0; i < given.size(); ++i) {
    difference |= static_cast<unsigned char>(given[i] ^ expected[i % expected.size()]);
  }
  return difference == 0;
}

std::string ip_of_grpc_peer(const std::string& peer) {
  auto decoded = [](std::string text) {
    // gRPC percent-encodes the brackets of an IPv6 peer in some versions.
    for (const char* code : {"%5B", "%5b"}) {
      for (size_t at; (at = text.find(code)) != std::string::npos;) text.replace(at, 3, "[");
    }
    for (const char* code : {"%5D", "%5d"}) {
      for (size_t at; (at = text.find(code)) != std::string::npos;) text.replace(at, 3, "]");
    }
    return text;
  };
  if (peer.rfind("ipv4:", 0) == 0) {
    const std::string rest = peer.substr(5);
    return rest.substr(0, rest.rfind(':'));
  }
  if (peer.rfind("ipv6:", 0) == 0) {
    const std::string rest = decoded(peer.substr(5));
    const size_t open = rest.find('['), close = rest.find(']');
    if (open == std::string::npos || close == std::string::npos || close < open) return "";
    return rest.substr(open + 1, close - open - 1);
  }
  return "";
}

std::string canonical_ip(const std::string& ip) {
  in6_addr v6{};
  if (inet_pton(AF_INET6, ip.c_str(), &v6) != 1) return ip;
  static const unsigned char kMappedPrefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
  if (std::memcmp(v6.s6_addr, kMappedPrefix, 12) != 0) return ip;
  char text[INET_ADDRSTRLEN];
  return inet_ntop(AF_INET, v6.s6_addr + 12, text, sizeof text) != nullptr ? std::string(text) : ip;
}

bool is_loopback_ip(const std::string& ip) {
  const std::string address = canonical_ip(ip);
  in_addr v4{};
  if (inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, address.c_str(), &v6) != 1) return false;
  static const unsigned char kLoopback[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  return std::memcmp(v6.s6_addr, kLoopback, 16) == 0;
}

bool listens_beyond_loopback(const std::string& address) {
  std::string host = address;
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (lowercase(host) == "localhost") return false;
  return !is_loopback_ip(host);
}

}  // namespace mm::service
