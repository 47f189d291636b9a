#include "server/core/caller_identity.h"

#include <arpa/inet.h>

#include <cctype>
#include <cstring>

namespace mm::service {

namespace {

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

std::string authorization_refusal(const std::string& problem, bool server_has_token) {
  if (problem != ::mm::wire::kBearerWithoutToken) return problem;
  if (!server_has_token) return "";
  return problem + ": this server has a token; send Authorization: Bearer <token> (is $TOKEN set?)";
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
