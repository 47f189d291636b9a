// The REST frontend's own job, against a fake core (tests/server/fake_core.h):
// the real frontend on a loopback port and httplib's client, so that what is
// pinned is the frontend alone: a request's JSON fields and query parameters
// reach the core as sent, the core's reply comes back as JSON, each of the
// core's refusals maps to its HTTP status and names its field, and what JSON
// itself gets wrong is refused without calling the core, and a body or reply
// of the model's skeleton (BVH) is read and written for the model the core
// chose before the operation (Core::choose_model), never by the core. No
// model, no LibTorch: each test takes milliseconds.
#include <gtest/gtest.h>
#include <httplib.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "format/h36m_bvh.h"
#include "format/motion_frames.h"
#include "server/core/service_metrics.h"
#include "server/rest/rest_frontend.h"
#include "tests/server/fake_core.h"
#include "tests/server/fake_core_exchange.h"
#include "tests/server/rest_call.h"

namespace mm {
namespace {

using json = nlohmann::json;
using service::ApiError;
using service::ErrorCode;

class RestFrontendFakeCore : public ::testing::Test {
 protected:
  void SetUp() override {
    service::RestOptions options;
    options.address = "127.0.0.1";
    options.port = 0;
    options.threads = 2;
    options.watch_streams = 1;
    frontend_ = std::make_unique<service::RestFrontend>(core_, metrics_, options);
    frontend_->start();
    port_ = frontend_->port();
  }
  void TearDown() override { frontend_->shutdown(); }

  test::Reply post_json(const std::string& path, const json& body) { return test::post(port_, path, body); }

  // The shape of a model of `columns` values a frame (H3.6M's skeleton).
  static service::ModelShape shape_of_columns(int columns) {
    service::ModelShape shape;
    shape.columns = columns;
    return shape;
  }

  test::FakeCore core_;
  service::ServiceMetrics metrics_;
  std::unique_ptr<service::RestFrontend> frontend_;
  int port_ = -1;
};

TEST_F(RestFrontendFakeCore, DecodeFieldsReachTheCoreAsSent) {
  core_.decode_answer.reply = test::one_motion_reply();
  const test::Reply reply = post_json(
      "/v1/decode",
      {{"model", "m1"}, {"codes", {{0.5, -1.25}, {2, 3}}}, {"decoder", "velocity"}, {"plant_feet", true}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  test::expect_the_decode_sent(core_.decode_request);
  EXPECT_EQ(core_.context.protocol, "rest");
  EXPECT_EQ(core_.context.peer_ip, "127.0.0.1");
}

TEST_F(RestFrontendFakeCore, TheCoresReplyComesBackAsJson) {
  core_.decode_answer.reply = test::one_motion_reply();
  const test::Reply reply = post_json("/v1/decode", {{"codes", {{0.5}}}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  const json& doc = reply.document;
  EXPECT_EQ(doc.at("answered_by").at("model"), "fake-model");
  EXPECT_EQ(doc.at("answered_by").at("version"), "0123456789abcdef");
  ASSERT_EQ(doc.at("motions").size(), 1u);
  const json& motion = doc.at("motions")[0];
  EXPECT_EQ(motion.at("frames"), 2);
  EXPECT_EQ(motion.at("columns"), 3);
  EXPECT_EQ(motion.at("frame_rate"), 25.0);
  EXPECT_EQ(motion.at("layout"), "test-layout-3");
  EXPECT_EQ(motion.at("values"), json({1, 2, 3, 4, 5, 6.5}));
  EXPECT_EQ(motion.at("root"), "generated");
  EXPECT_EQ(motion.at("contacts"), json({1, 2}));
  EXPECT_EQ(doc.at("codes"), json({{0.25, -0.5}}));
}

TEST_F(RestFrontendFakeCore, SampleFieldsReachTheCoreAsSent) {
  core_.sample_answer.reply = test::one_motion_reply();
  const test::Reply reply = post_json(
      "/v1/sample", {{"model", "m2"}, {"count", 3}, {"seed", 18446744073709551615ull}, {"decoder", "rotation"}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  test::expect_the_sample_sent(core_.sample_request);
}

// Each of the core's refusals: its HTTP status, and its code, field and
// message in the error body.
struct Refusal {
  ApiError error;
  int status;
  std::string code;
};

TEST_F(RestFrontendFakeCore, TheCoresRefusalsMapToTheirStatusWithTheirField) {
  const Refusal refusals[] = {
      {ApiError(ErrorCode::kInvalidArgument, "codes[1]", "expected 64 values, got 2"), 400, "INVALID_ARGUMENT"},
      {ApiError(ErrorCode::kNotFound, "model", "no model \"m9\""), 404, "NOT_FOUND"},
      {ApiError(ErrorCode::kResourceExhausted, "codes", "65 codes, more than --max-motions 64", true), 413,
       "RESOURCE_EXHAUSTED"},
      {ApiError(ErrorCode::kResourceExhausted, "", "the executor's queue is full (256)"), 429, "RESOURCE_EXHAUSTED"},
      {ApiError(ErrorCode::kFailedPrecondition, "model", "the state forbids it"), 409, "FAILED_PRECONDITION"},
      {ApiError(ErrorCode::kUnavailable, "", "shutting down"), 503, "UNAVAILABLE"},
  };
  for (const Refusal& refusal : refusals) {
    SCOPED_TRACE(refusal.code + " " + refusal.error.what());
    core_.decode_answer.error = refusal.error;
    const test::Reply reply = post_json("/v1/decode", {{"codes", {{0.5}}}});
    EXPECT_EQ(reply.status, refusal.status) << reply.body;
    ASSERT_TRUE(reply.document.is_object()) << reply.body;
    EXPECT_EQ(reply.error().at("code"), refusal.code);
    EXPECT_EQ(reply.field(), refusal.error.field());
    EXPECT_EQ(reply.error().at("message"), refusal.error.what());
    EXPECT_EQ(reply.header("WWW-Authenticate"), "");
  }
}

TEST_F(RestFrontendFakeCore, UnauthenticatedIs401WithWwwAuthenticate) {
  core_.decode_answer.error = ApiError(ErrorCode::kUnauthenticated, "", "this call needs the bearer token");
  const test::Reply reply = test::post(port_, "/v1/decode", json{{"codes", {{0.5}}}}, test::bearer("wrong"));
  EXPECT_EQ(reply.status, 401) << reply.body;
  EXPECT_EQ(reply.header("WWW-Authenticate"), "Bearer");
  EXPECT_EQ(reply.error().at("code"), "UNAUTHENTICATED");
  EXPECT_EQ(core_.context.bearer_token, "wrong");  // the header's token reached the core
}

TEST_F(RestFrontendFakeCore, AnUnknownJsonFieldIsRefusedWithoutCallingTheCore) {
  core_.decode_answer.reply = test::one_motion_reply();
  const test::Reply reply = post_json("/v1/decode", {{"codes", {{0.5}}}, {"plant_foot", true}});
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_EQ(reply.field(), "plant_foot");
  const std::string message = reply.error().at("message").get<std::string>();
  EXPECT_NE(message.find("unknown field"), std::string::npos) << reply.body;
  EXPECT_NE(message.find("plant_feet"), std::string::npos) << reply.body;  // the fields it knows
  EXPECT_EQ(core_.calls, 0);
}

TEST_F(RestFrontendFakeCore, AFieldOfTheWrongTypeIsRefusedWithoutCallingTheCore) {
  const test::Reply reply = post_json("/v1/sample", {{"count", "three"}});
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_EQ(reply.field(), "count");
  EXPECT_EQ(core_.calls, 0);
}

// A BVH body is of the skeleton of the model that answers: the frontend
// chooses the model first, reads the body for that model's shape, and runs
// the operation on the model it chose (the core reads no body).
TEST_F(RestFrontendFakeCore, ABvhBodyIsReadForTheModelChosenBeforeTheCall) {
  core_.choose_answer.reply = service::ModelShape();  // H3.6M's: 150 frames of 99 values
  service::EncodeReply answer;
  answer.answered_by = {"m5", test::FakeCore::kChosenVersion};
  answer.codes = {{0.25f}};
  core_.encode_answer.reply = answer;
  MotionFrames still;
  still.values.assign(150 * static_cast<size_t>(still.columns), 0.0f);
  const test::Reply reply =
      test::post(port_, "/v1/encode?model=m5", h36m_motion_to_bvh_text(still, 25), {}, "application/x-bvh");
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(core_.steps, (std::vector<std::string>{"choose_model encode m5", "encode on chosen m5"}));
  ASSERT_TRUE(core_.encode_request.has_value());
  ASSERT_EQ(core_.encode_request->motions.size(), 1u);
  const service::Motion& motion = core_.encode_request->motions[0];
  EXPECT_EQ(motion.frames, 150);
  EXPECT_EQ(motion.columns, 99);
  EXPECT_EQ(reply.document.at("codes"), json({{0.25}}));
}

// A body that cannot be read for the chosen model ends its call through the
// core (counted there as the call's refusal), and no operation runs.
TEST_F(RestFrontendFakeCore, ABodyUnreadableForTheChosenModelIsRefusedThroughTheCore) {
  core_.choose_answer.reply = service::ModelShape();
  core_.encode_answer.reply = service::EncodeReply();
  const test::Reply reply =
      test::post(port_, "/v1/encode?model=m5", std::string("HIERARCHY\nnot a joint\n"), {}, "application/x-bvh");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.error().at("message").get<std::string>().find("request body:"), std::string::npos) << reply.body;
  EXPECT_EQ(core_.steps,
            (std::vector<std::string>{"choose_model encode m5", "refuse_body encode INVALID_ARGUMENT"}));
  EXPECT_FALSE(core_.encode_request.has_value());
}

// A BVH reply is of the skeleton of the model chosen before the call; a
// JSON reply chooses none (the core resolves the request's model).
TEST_F(RestFrontendFakeCore, ABvhReplyIsWrittenForTheModelChosenBeforeTheCall) {
  core_.choose_answer.reply = service::ModelShape();
  service::MotionsReply answer = test::one_motion_reply();
  service::Motion& motion = answer.motions[0];
  motion.columns = 99;
  motion.layout = service::kH36mLayout;
  motion.values.assign(2 * 99, 0.0f);
  core_.decode_answer.reply = answer;
  const test::Reply reply =
      test::post(port_, "/v1/decode", json{{"model", "m1"}, {"codes", {{0.5}}}}.dump(), {{"Accept", "application/x-bvh"}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.header("Content-Type"), "application/x-bvh");
  EXPECT_EQ(reply.body.rfind("HIERARCHY", 0), 0u) << reply.body.substr(0, 80);
  EXPECT_EQ(core_.steps, (std::vector<std::string>{"choose_model decode m1", "decode on chosen m1"}));

  core_.steps.clear();
  ASSERT_EQ(post_json("/v1/decode", {{"model", "m1"}, {"codes", {{0.5}}}}).status, 200);
  EXPECT_EQ(core_.steps, (std::vector<std::string>{"decode on request m1"}));
}

TEST_F(RestFrontendFakeCore, ATakeRoutesQueryReachesTheCore) {
  core_.choose_answer.reply = shape_of_columns(3);
  core_.take_answer.error = ApiError(ErrorCode::kNotFound, "model", "no model \"m3\"");
  const test::Reply reply = test::post(
      port_, "/v1/takes:reconstruct?model=m3&frame_rate=120&hop_seconds=1.5&blend=cut&decoder=velocity&root=input",
      std::string("1,2,3\n4,5,6\n"), {}, "text/plain");
  EXPECT_EQ(reply.status, 404) << reply.body;
  EXPECT_EQ(reply.field(), "model");
  ASSERT_TRUE(core_.take_request.has_value());
  EXPECT_EQ(core_.take_operation, TakeOperation::kReconstruct);
  const service::TakeRequest& sent = *core_.take_request;
  EXPECT_EQ(sent.model, "m3");
  EXPECT_EQ(sent.frame_rate, 120);
  EXPECT_EQ(sent.hop_seconds, 1.5);
  EXPECT_EQ(sent.blend, "cut");
  EXPECT_EQ(sent.decoder, "velocity");
  EXPECT_EQ(sent.root, "input");
  EXPECT_EQ(sent.path, "");
  // The model first, then the body read in its 3 columns (2 frames), handed
  // to the take as its reader.
  EXPECT_EQ(core_.steps, (std::vector<std::string>{"choose_model reconstruct_take m3",
                                                   "reconstruct_take on chosen m3"}));
  EXPECT_EQ(core_.take_frames_read, 2);
}

TEST_F(RestFrontendFakeCore, AnUnknownQueryParameterOfATakeIsRefusedWithoutCallingTheCore) {
  const test::Reply reply =
      test::post(port_, "/v1/takes:reconstruct?hop=1.5", std::string("1 2 3\n"), {}, "text/plain");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_EQ(reply.field(), "hop");
  EXPECT_EQ(core_.calls, 0);
}

}  // namespace
}  // namespace mm
