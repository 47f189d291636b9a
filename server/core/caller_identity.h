// Who is calling, as both frontends read it from their wire: the bearer
// token of the Authorization header (one parser, wire/bearer_token.h, so
// that gRPC and REST accept and refuse exactly the same headers as the
// client writes them) and the caller's IP address (calls that change state
// are taken without a token only from loopback).
//
// Torch-free and wire-free. Thread safety: pure functions.
#pragma once

#include <string>
#include <vector>

#include "wire/bearer_token.h"

namespace mm::service {

// The bearer token: parsed by the code the client writes it with
// (wire/bearer_token.h), so that the two sides cannot drift.
using ::mm::wire::BearerCredentials;
using ::mm::wire::kMaxBearerTokenBytes;
using ::mm::wire::parse_authorization;

// Why a call's Authorization header is refused before any token is
// compared: `problem` as parse_authorization gave it, or "" to go on. On a
// server without a token (`server_has_token` false) "Bearer" with nothing
// after it (a script's empty $TOKEN) is no header, so such a call is let in
// from loopback as one without the header is; on a server with a token it
// is refused saying so and that the token is missing.
std::string authorization_refusal(const std::string& problem, bool server_has_token);

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
