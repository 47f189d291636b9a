// The error model on gRPC: the core's ApiError as a grpc::Status, one
// mapping for every rpc (README of proto/ lists it).
//
// Thread safety: pure functions; `context` is the calling rpc's own.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include "server/api/api_types.h"

namespace mm::service::grpc_frontend {

// Trailing metadata key naming the request field at fault, in the wire's own
// spelling ("motions[0].frames"); absent when no one field is.
constexpr const char* kErrorFieldKey = "mm-error-field";

grpc::StatusCode status_code(ErrorCode code);

// The status of a refused call: the mapped code, the message
// "<field>: <message>" (just the message when field is empty), and the field
// in the trailing metadata of `context`.
grpc::Status error_status(const ApiError& error, grpc::ServerContext* context);

}  // namespace mm::service::grpc_frontend
