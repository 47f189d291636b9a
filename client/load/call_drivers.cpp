#include "client/load/call_drivers.h"

#include <grpcpp/grpcpp.h>
#include <httplib.h>

#include <random>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "wire/rest_error.h"
#include "wire/rest_json.h"

namespace mm::client {
namespace {

namespace v1 = motionmanifold::v1;
constexpr int kLatent = 64;

std::vector<float> random_code(std::mt19937& engine) {
  std::normal_distribution<float> normal;
  std::vector<float> code(kLatent);
  for (auto& v : code) v = normal(engine);
  return code;
}

const char* status_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    default: return "OTHER";
  }
}

// The requests a driver sends, the same for both protocols: `call.batch`
// codes drawn from N(0, I) by `seed` to decode, as many copies of the
// call's motion to encode, or a sample of `call.batch` motions.
struct LoadRequests {
  v1::DecodeRequest decode;
  v1::EncodeRequest encode;
  v1::SampleRequest sample;

  LoadRequests(const LoadCall& call, unsigned seed) {
    std::mt19937 engine(seed);
    decode.set_model(call.model);
    for (int i = 0; i < call.batch; ++i) {
      const auto code = random_code(engine);
      decode.add_codes()->mutable_values()->Add(code.begin(), code.end());
    }
    encode.set_model(call.model);
    for (int i = 0; i < call.batch && !call.motion_values.empty(); ++i) {
      auto* motion = encode.add_motions();
      motion->set_frames(call.motion_frames);
      motion->set_columns(99);
      motion->set_frame_rate(call.motion_frame_rate);
      motion->set_layout("h36m-expmap-99");
      motion->mutable_values()->Add(call.motion_values.begin(), call.motion_values.end());
    }
    sample.set_model(call.model);
    sample.set_count(call.batch);
    sample.set_seed(seed);
  }
};

class GrpcDriver : public CallDriver {
 public:
  GrpcDriver(const std::string& target, const LoadCall& call, unsigned seed)
      : operation_(call.operation), requests_(call, seed) {
    // A channel of its own (no shared subchannel), as separate clients have.
    grpc::ChannelArguments arguments;
    arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    arguments.SetMaxReceiveMessageSize(256 << 20);
    arguments.SetMaxSendMessageSize(256 << 20);
    stub_ = v1::MotionManifold::NewStub(grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), arguments));
  }

  std::string call() override {
    grpc::ClientContext context;
    grpc::Status status;
    if (operation_ == "decode") {
      v1::MotionsReply reply;
      status = stub_->Decode(&context, requests_.decode, &reply);
    } else if (operation_ == "encode") {
      v1::EncodeReply reply;
      status = stub_->Encode(&context, requests_.encode, &reply);
    } else {
      v1::MotionsReply reply;
      status = stub_->Sample(&context, requests_.sample, &reply);
    }
    return status_name(status.error_code());
  }

 private:
  std::string operation_;
  std::unique_ptr<v1::MotionManifold::Stub> stub_;
  LoadRequests requests_;
};

class RestDriver : public CallDriver {
 public:
  RestDriver(const std::string& host, int port, const LoadCall& call, unsigned seed)
      : client_(host, port), path_("/v1/" + call.operation) {
    client_.set_keep_alive(true);
    client_.set_tcp_nodelay(true);  // headers and body go out in two writes
    client_.set_read_timeout(120, 0);
    // The body as the client writes it (wire/rest_json.h).
    const LoadRequests requests(call, seed);
    body_ = call.operation == "decode"   ? ::mm::wire::body_text(::mm::wire::to_json(requests.decode))
            : call.operation == "encode" ? ::mm::wire::body_text(::mm::wire::to_json(requests.encode))
                                         : ::mm::wire::body_text(::mm::wire::to_json(requests.sample));
  }

  std::string call() override {
    const auto result = client_.Post(path_.c_str(), body_, "application/json");
    if (!result) return "CONNECTION:" + httplib::to_string(result.error());
    if (result->status == 200) return "OK";
    std::string code = "HTTP " + std::to_string(result->status);
    if (const auto error = wire::rest_error_from_body(result->body, "")) code += " " + error->code;
    return code;
  }

 private:
  httplib::Client client_;
  std::string path_, body_;
};

}  // namespace

std::unique_ptr<CallDriver> grpc_driver(const std::string& target, const LoadCall& call, unsigned seed) {
  return std::make_unique<GrpcDriver>(target, call, seed);
}

std::unique_ptr<CallDriver> rest_driver(const std::string& host, int port, const LoadCall& call, unsigned seed) {
  return std::make_unique<RestDriver>(host, port, call, seed);
}

}  // namespace mm::client
