#include "server/rest/http_errors.h"

#include "wire/rest_error.h"

namespace mm::service::rest {

int http_status(const ApiError& error) {
  switch (error.code()) {
    case ErrorCode::kInvalidArgument: return 400;
    case ErrorCode::kNotFound: return 404;
    case ErrorCode::kFailedPrecondition: return 409;
    case ErrorCode::kResourceExhausted: return error.too_large() ? 413 : 429;
    case ErrorCode::kUnauthenticated: return 401;
    case ErrorCode::kUnavailable: return 503;
    case ErrorCode::kInternal: return 500;
  }
  return 500;
}

std::string error_body(const std::string& code_name, const std::string& field, const std::string& message) {
  // The body's layout is the client's too: one definition in wire/.
  return ::mm::wire::rest_error_body({code_name, field, message});
}

std::string error_body(const ApiError& error) {
  return error_body(error_code_name(error.code()), error.field(), error.what());
}

const char* error_code_name_for_status(int status) {
  switch (status) {
    case 400: return "INVALID_ARGUMENT";
    case 401: return "UNAUTHENTICATED";
    case 404: return "NOT_FOUND";
    case 409: return "FAILED_PRECONDITION";
    case 413:
    case 429: return "RESOURCE_EXHAUSTED";
    case 503: return "UNAVAILABLE";
    default: return status < 500 ? "INVALID_ARGUMENT" : "INTERNAL";
  }
}

}  // namespace mm::service::rest
