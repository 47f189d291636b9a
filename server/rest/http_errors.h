// The error model on HTTP: an ApiError's code as an HTTP status (the twin of
// the gRPC status the gRPC frontend sends) and the JSON error body
//   {"error": {"code": "INVALID_ARGUMENT", "field": "motions[0].columns", "message": "..."}}
// that every failing route answers, including the HTTP layer's own refusals.
// Thread safety: pure functions; call from any thread.
#pragma once

#include <string>

#include "server/api/api_types.h"

namespace mm::service::rest {

// INVALID_ARGUMENT 400, NOT_FOUND 404, FAILED_PRECONDITION 409,
// RESOURCE_EXHAUSTED 413 (too_large) or 429, UNAUTHENTICATED 401,
// UNAVAILABLE 503, INTERNAL 500.
int http_status(const ApiError& error);

// The JSON error body (one line, no trailing newline).
std::string error_body(const std::string& code_name, const std::string& field, const std::string& message);
std::string error_body(const ApiError& error);

// The error code that an HTTP status raised by the HTTP layer itself (not by
// the core) stands for: 400 INVALID_ARGUMENT, 401 UNAUTHENTICATED,
// 404 NOT_FOUND, 409 FAILED_PRECONDITION, 413 and 429 RESOURCE_EXHAUSTED,
// 503 UNAVAILABLE; any other 4xx INVALID_ARGUMENT, 5xx INTERNAL.
const char* error_code_name_for_status(int status);

}  // namespace mm::service::rest
