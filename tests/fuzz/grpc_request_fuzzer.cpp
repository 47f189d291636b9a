// libFuzzer target: one gRPC request into the real core, through the real
// gRPC frontend (GrpcFrontend, as the server starts it) on 127.0.0.1: the
// request's bytes are sent as they are, so the server's gRPC parses them as
// the rpc's request message, ManifoldService translates them
// (proto_translation.cpp) and calls the core from loopback with no token,
// so writes are let in.
//
// An input is the rpc's name, a newline, then the message's bytes:
//   Encode\n<serialized motionmanifold.v1.EncodeRequest>
// Any rpc of motionmanifold.v1.MotionManifold may be named (WatchJob, the
// stream, is called as a unary call: it answers at once for a job that is
// not there).
// An INTERNAL status to bytes that parse as the request aborts: gRPC answers
// INTERNAL itself only to bytes that do not parse; after that every request
// deserves an answer that is not INTERNAL.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "motionmanifold/v1/manifold.pb.h"
#include "server/grpc/grpc_frontend.h"
#include "tests/fuzz/fuzz_service.h"

namespace {

namespace protobuf = google::protobuf;

struct GrpcTarget {
  mm::service::GrpcFrontend frontend;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<grpc::GenericStub> stub;
  grpc::CompletionQueue queue;
  protobuf::DynamicMessageFactory factory;
  std::map<std::string, const protobuf::MethodDescriptor*> methods;  // by rpc name

  GrpcTarget() : frontend(mm::fuzz::fuzz_service().core, options()) {
    frontend.start();
    grpc::ChannelArguments arguments;
    arguments.SetMaxSendMessageSize(-1);  // the server's limit is the one to meet
    channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(frontend.port()),
                                        grpc::InsecureChannelCredentials(), arguments);
    stub = std::make_unique<grpc::GenericStub>(channel);
    const auto* service = motionmanifold::v1::EncodeRequest::descriptor()->file()->FindServiceByName("MotionManifold");
    for (int i = 0; i < service->method_count(); ++i) methods[service->method(i)->name()] = service->method(i);
  }

  static mm::service::GrpcOptions options() {
    mm::service::GrpcOptions grpc;
    grpc.address = "127.0.0.1";
    grpc.port = 0;
    return grpc;
  }

  // Whether `bytes` parse as the request message of `method`, as the
  // server's gRPC parses them.
  bool parses(const protobuf::MethodDescriptor& method, const std::string& bytes) {
    std::unique_ptr<protobuf::Message> message(factory.GetPrototype(method.input_type())->New());
    return message->ParseFromString(bytes);
  }
};

GrpcTarget& target() {
  static GrpcTarget* made = [] {
    auto* created = new GrpcTarget();
    // Registered after the core's own: runs before it, while the core lives.
    std::atexit([] { target().frontend.shutdown(std::chrono::seconds(1)); });
    return created;
  }();
  return *made;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Bytes that are not the message make protobuf log an error each time.
  google::protobuf::SetLogHandler(nullptr);
  target();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t newline = input.find('\n');
  if (newline == std::string::npos) return 0;
  GrpcTarget& grpc_target = target();
  const auto found = grpc_target.methods.find(input.substr(0, newline));
  if (found == grpc_target.methods.end()) return 0;
  const protobuf::MethodDescriptor& method = *found->second;
  const std::string bytes = input.substr(newline + 1);

  // Called on this thread's own completion queue: no hop through gRPC's
  // callback threads, which on two busy cores cost milliseconds a call.
  grpc::Slice slice(bytes);
  const grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer reply;
  grpc::ClientContext context;
  grpc::Status status;
  auto call = grpc_target.stub->PrepareUnaryCall(&context, "/" + method.service()->full_name() + "/" + method.name(),
                                                 request, &grpc_target.queue);
  call->StartCall();
  call->Finish(&reply, &status, &grpc_target);
  void* tag = nullptr;
  bool ok = false;
  grpc_target.queue.Next(&tag, &ok);
  mm::fuzz::print_answer_when_verbose(method.name(), status.error_code(), status.error_message());
  if (status.error_code() == grpc::StatusCode::INTERNAL && grpc_target.parses(method, bytes))
    mm::fuzz::report_internal_error(method.name(), status.error_message());
  return 0;
}
