// The bearer token of the Authorization header, written by the client and
// read by the server from one definition, so that what one side sends is what
// the other accepts. Both protocols carry it alike: REST as the
// `Authorization` header, gRPC as the `authorization` metadata.
//
// Plain C++ (no LibTorch, no gRPC, no HTTP library). Thread safety: pure
// functions; call from any thread.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace mm::wire {

// Longer tokens are refused before they are compared: a token is a secret of
// a few dozen characters, not a payload.
constexpr size_t kMaxBearerTokenBytes = 4096;

// The Authorization header's value that carries `token`: "Bearer <token>".
std::string bearer_authorization(const std::string& token);

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

// The problem parse_authorization gives for "Bearer" with no token, as a
// script writes it from an unset variable (`Authorization: Bearer $TOKEN`):
// a server without a token takes such a header as none
// (server/core/caller_identity.h).
extern const char kBearerWithoutToken[];

}  // namespace mm::wire
