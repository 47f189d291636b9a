// Who is calling, as both frontends read it from their wire: the bearer
// token of the Authorization header (one parser, so that gRPC and REST
// accept and refuse exactly the same headers) and the caller's IP address
// (calls that change state are taken without a token only from loopback).
//
// Torch-free and wire-free. Thread safety: pure functions.
#pragma once

#include <string>
#include <vector>

namespace mm::service {

// Longer tokens are refused before they are compared: a token is a secret of
// a few dozen characters, not a payload.
constexpr size_t kMaxBearerTokenBytes = 4096;

// What the Authorization headers of a call say. `token` is set when exactly
// one header holds "Bearer <token>" (the scheme in any case, RFC 7235; spaces
// and tabs around the token ignored, the token itself visible ASCII);
// `problem` says why a header that is present is not that (another scheme,
// no token, two headers, a control character, too long). Neither: no header
// (a blank one counts as none).
struct BearerCredentials {
  std::string token;
  std::string problem;
};
BearerCredentials parse_authorization(const std::vector<std::string>& header_values);

// Whether `given` is `expected`, in a time that depends on the length of
// `given` only, never on how much of it matches.
bool tokens_equal(const std::string& given, const std::string& expected);

// The IP address in a gRPC peer string ("ipv4:127.0.0.1:5000",
// "ipv6:[::1]:5000", "ipv6:%5B::1%5D:5000"); empty for other transports.
std::string ip_of_grpc_peer(const std::string& peer);

// One client, one spelling: an IPv4 client of a dual-stack listener shows as
// "::ffff:a.b.c.d" on one frontend and as "a.b.c.d" on the other, so an
// IPv4-mapped IPv6 address is given as its IPv4 address; any other as it is.
// Both frontends fill CallContext::peer_ip with it, so that the limits kept
// per caller address (watch streams, queued jobs) count a client once.
std::string canonical_ip(const std::string& ip);

// Whether `ip` (as "127.0.0.1", "::1" or "::ffff:127.0.0.1") is a loopback
// address: 127.0.0.0/8, ::1, or an IPv4-mapped loopback address.
bool is_loopback_ip(const std::string& ip);

// Whether listening on `address` ("0.0.0.0", "127.0.0.1", "::", "localhost")
// reaches beyond this machine.
bool listens_beyond_loopback(const std::string& address);

}  // namespace mm::service
