// gRPC calls to a test server on loopback, for the suites that drive a real
// server over both protocols: a stub on a channel without message limits,
// a context with a deadline and, when given, a bearer token, and the error
// field the server names in its trailing metadata.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

#include "motionmanifold/v1/manifold.grpc.pb.h"

namespace mm::test {

inline std::unique_ptr<::motionmanifold::v1::MotionManifold::Stub> grpc_stub(const std::string& target) {
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  arguments.SetMaxSendMessageSize(-1);
  return ::motionmanifold::v1::MotionManifold::NewStub(
      grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), arguments));
}

// A context for one call: a deadline long enough for a busy machine, and
// the token when it is not empty.
inline std::unique_ptr<grpc::ClientContext> grpc_context(const std::string& token = "") {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
  return context;
}

// The request field a refusal names (trailing metadata mm-error-field).
inline std::string grpc_error_field(const grpc::ClientContext& context) {
  const auto& trailing = context.GetServerTrailingMetadata();
  const auto found = trailing.find("mm-error-field");
  return found == trailing.end() ? "(none)" : std::string(found->second.data(), found->second.size());
}

}  // namespace mm::test
