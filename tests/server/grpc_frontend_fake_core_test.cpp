// The gRPC frontend's own job, against a fake core (tests/server/fake_core.h):
// the real frontend on a loopback port and a real stub, so that what is
// pinned is the frontend alone: a message's fields reach the core as sent,
// the core's reply comes back as the proto's message, and each of the core's
// refusals maps to its status code with its field in the message and the
// trailing metadata. No model, no LibTorch: each test takes milliseconds.
#include <gtest/gtest.h>

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "server/grpc/error_status.h"
#include "server/grpc/grpc_frontend.h"
#include "tests/server/fake_core.h"
#include "tests/server/fake_core_exchange.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using grpc::StatusCode;
using service::ApiError;
using service::ErrorCode;

class GrpcFrontendFakeCore : public ::testing::Test {
 protected:
  void SetUp() override {
    service::GrpcOptions options;
    options.address = "127.0.0.1";
    options.port = 0;
    options.max_threads = 8;
    options.max_streams_per_connection = 4;
    options.watch_streams = 1;
    frontend_ = std::make_unique<service::GrpcFrontend>(core_, options);
    frontend_->start();
    stub_ = v1::MotionManifold::NewStub(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(frontend_->port()), grpc::InsecureChannelCredentials()));
  }
  void TearDown() override { frontend_->shutdown(std::chrono::milliseconds(100)); }

  static void deadline(grpc::ClientContext& context) {
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  }

  test::FakeCore core_;
  std::unique_ptr<service::GrpcFrontend> frontend_;
  std::unique_ptr<v1::MotionManifold::Stub> stub_;
};

v1::DecodeRequest decode_message() {
  v1::DecodeRequest request;
  request.set_model("m1");
  for (const auto& values : {std::vector<float>{0.5f, -1.25f}, std::vector<float>{2, 3}}) {
    auto* code = request.add_codes();
    for (float v : values) code->add_values(v);
  }
  request.set_decoder("velocity");
  request.set_plant_feet(true);
  return request;
}

TEST_F(GrpcFrontendFakeCore, DecodeFieldsReachTheCoreAsSent) {
  core_.decode_answer.reply = test::one_motion_reply();
  grpc::ClientContext context;
  deadline(context);
  context.AddMetadata("authorization", "Bearer sesame");
  v1::MotionsReply reply;
  const grpc::Status status = stub_->Decode(&context, decode_message(), &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
  test::expect_the_decode_sent(core_.decode_request);
  EXPECT_EQ(core_.context.protocol, "grpc");
  EXPECT_EQ(core_.context.bearer_token, "sesame");
  EXPECT_EQ(core_.context.peer_ip, "127.0.0.1");
}

TEST_F(GrpcFrontendFakeCore, TheCoresReplyComesBackAsTheMessage) {
  core_.decode_answer.reply = test::one_motion_reply();
  grpc::ClientContext context;
  deadline(context);
  v1::MotionsReply reply;
  ASSERT_TRUE(stub_->Decode(&context, decode_message(), &reply).ok());
  EXPECT_EQ(reply.answered_by().model(), "fake-model");
  EXPECT_EQ(reply.answered_by().version(), "0123456789abcdef");
  ASSERT_EQ(reply.motions_size(), 1);
  const v1::Motion& motion = reply.motions(0);
  EXPECT_EQ(motion.frames(), 2);
  EXPECT_EQ(motion.columns(), 3);
  EXPECT_EQ(motion.frame_rate(), 25);
  EXPECT_EQ(motion.layout(), "test-layout-3");
  EXPECT_EQ(std::vector<float>(motion.values().begin(), motion.values().end()),
            (std::vector<float>{1, 2, 3, 4, 5, 6.5f}));
  EXPECT_EQ(motion.root(), "generated");
  EXPECT_EQ(std::vector<uint32_t>(motion.contacts().begin(), motion.contacts().end()), (std::vector<uint32_t>{1, 2}));
  ASSERT_EQ(reply.codes_size(), 1);
  EXPECT_EQ(std::vector<float>(reply.codes(0).values().begin(), reply.codes(0).values().end()),
            (std::vector<float>{0.25f, -0.5f}));
}

TEST_F(GrpcFrontendFakeCore, SampleFieldsReachTheCoreAsSent) {
  core_.sample_answer.reply = test::one_motion_reply();
  v1::SampleRequest request;
  request.set_model("m2");
  request.set_count(3);
  request.set_seed(18446744073709551615ull);
  request.set_decoder("rotation");
  grpc::ClientContext context;
  deadline(context);
  v1::MotionsReply reply;
  ASSERT_TRUE(stub_->Sample(&context, request, &reply).ok());
  test::expect_the_sample_sent(core_.sample_request);
  EXPECT_EQ(reply.motions_size(), 1);
}

// Each of the core's refusals: its status code, the message "<field>: ..."
// and the field in the trailing metadata.
struct Refusal {
  ApiError error;
  StatusCode code;
};

TEST_F(GrpcFrontendFakeCore, TheCoresRefusalsMapToTheirStatusWithTheirField) {
  const Refusal refusals[] = {
      {ApiError(ErrorCode::kInvalidArgument, "codes[1]", "expected 64 values, got 2"), StatusCode::INVALID_ARGUMENT},
      {ApiError(ErrorCode::kNotFound, "model", "no model \"m9\""), StatusCode::NOT_FOUND},
      {ApiError(ErrorCode::kResourceExhausted, "codes", "65 codes, more than --max-motions 64", true),
       StatusCode::RESOURCE_EXHAUSTED},
      {ApiError(ErrorCode::kResourceExhausted, "", "the executor's queue is full (256)"),
       StatusCode::RESOURCE_EXHAUSTED},
      {ApiError(ErrorCode::kFailedPrecondition, "model", "the state forbids it"), StatusCode::FAILED_PRECONDITION},
      {ApiError(ErrorCode::kUnauthenticated, "", "this call needs the bearer token"), StatusCode::UNAUTHENTICATED},
      {ApiError(ErrorCode::kUnavailable, "", "shutting down"), StatusCode::UNAVAILABLE},
  };
  for (const Refusal& refusal : refusals) {
    SCOPED_TRACE(refusal.error.what());
    core_.decode_answer.error = refusal.error;
    grpc::ClientContext context;
    deadline(context);
    v1::MotionsReply reply;
    const grpc::Status status = stub_->Decode(&context, decode_message(), &reply);
    EXPECT_EQ(status.error_code(), refusal.code) << status.error_message();
    const std::string& field = refusal.error.field();
    EXPECT_EQ(status.error_message(), field.empty() ? std::string(refusal.error.what())
                                                    : field + ": " + refusal.error.what());
    const auto& trailing = context.GetServerTrailingMetadata();
    const auto found = trailing.find(service::grpc_frontend::kErrorFieldKey);
    if (field.empty()) {
      EXPECT_EQ(found, trailing.end());
    } else {
      ASSERT_NE(found, trailing.end());
      EXPECT_EQ(std::string(found->second.data(), found->second.size()), field);
    }
  }
}

}  // namespace
}  // namespace mm
