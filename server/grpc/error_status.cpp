#include "server/grpc/error_status.h"

namespace mm::service::grpc_frontend {

grpc::StatusCode status_code(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return grpc::StatusCode::INVALID_ARGUMENT;
    case ErrorCode::kNotFound: return grpc::StatusCode::NOT_FOUND;
    case ErrorCode::kFailedPrecondition: return grpc::StatusCode::FAILED_PRECONDITION;
    case ErrorCode::kResourceExhausted: return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case ErrorCode::kUnauthenticated: return grpc::StatusCode::UNAUTHENTICATED;
    case ErrorCode::kUnavailable: return grpc::StatusCode::UNAVAILABLE;
    case ErrorCode::kInternal: return grpc::StatusCode::INTERNAL;
  }
  return grpc::StatusCode::INTERNAL;
}

grpc::Status error_status(const ApiError& error, grpc::ServerContext* context) {
  std::string message = error.what();
  if (!error.field().empty()) {
    // A library message that already opens with the field is not named twice.
    if (message.rfind(error.field() + ": ", 0) != 0) message = error.field() + ": " + message;
    context->AddTrailingMetadata(kErrorFieldKey, error.field());
  }
  return grpc::Status(status_code(error.code()), message);
}

}  // namespace mm::service::grpc_frontend
