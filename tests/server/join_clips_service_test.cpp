// JoinClips through the real server, over both protocols: two short S5 clips
// (4 s of walking, 4 s of sitting, sent at the files' 50 Hz) joined by a 1 s
// transition. The joined motion is clip a's frames (at 25 Hz) before the
// transition and clip b's after it, value for value; the generated
// transition meets both borders (the jump into and out of it under 1.5x the
// clips' median per-frame move) and differs from the crossfade of the same
// pair; over REST too, from JSON motions, and the crossfade from two BVH
// files in a multipart/form-data body; a transition of 5 s, a clip too short and an unknown method
// are refused naming the field. Torch-free: the expected values are the
// inputs themselves.
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "format/h36m_bvh.h"
#include "format/motion_text.h"
#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using json = nlohmann::json;

constexpr int kClipRows = 200;  // 4 s at 50 Hz: 100 frames at 25 Hz
constexpr int kTransitionFrames = 25;  // 1 s at 25 Hz

// The first `rows` rows of an S5 file at 50 Hz, as the data set holds it.
MotionFrames s5_rows(const std::string& name, int rows) {
  MotionFrames file = read_motion_text((test::h36m_dataset_dir() / "S5" / name).string());
  file.values.resize(static_cast<size_t>(rows) * file.columns);
  return file;
}

// What the server makes of a 50 Hz clip: every second row.
MotionFrames at_25hz(const MotionFrames& rows) {
  MotionFrames out;
  out.columns = rows.columns;
  for (int64_t f = 0; f < rows.frame_count(); f += 2) out.values.insert(out.values.end(), rows.frame(f), rows.frame(f) + rows.columns);
  return out;
}

v1::Motion wire_motion(const MotionFrames& frames, double rate) {
  v1::Motion motion;
  motion.set_frames(static_cast<int>(frames.frame_count()));
  motion.set_columns(frames.columns);
  motion.set_frame_rate(rate);
  motion.set_layout("h36m-expmap-99");
  motion.mutable_values()->Add(frames.values.begin(), frames.values.end());
  return motion;
}

json motion_json(const MotionFrames& frames, double rate) {
  return {{"frames", frames.frame_count()}, {"columns", frames.columns}, {"frame_rate", rate},
          {"layout", "h36m-expmap-99"}, {"values", frames.values}};
}

MotionFrames frames_of(const v1::Motion& motion) {
  MotionFrames out;
  out.columns = motion.columns();
  out.values.assign(motion.values().begin(), motion.values().end());
  return out;
}

MotionFrames frames_of(const json& motion) {
  MotionFrames out;
  out.columns = motion.at("columns").get<int>();
  out.values = motion.at("values").get<std::vector<float>>();
  return out;
}

// The distance between two frames' joint angles (radians; the root's
// per-frame moves, columns 0..2, left out).
double pose_distance(const float* x, const float* y, int columns) {
  double sum = 0;
  for (int c = kRootTranslationValues; c < columns; ++c) sum += (x[c] - y[c]) * (x[c] - y[c]);
  return std::sqrt(sum);
}

double median_move(const std::vector<const MotionFrames*>& clips) {
  std::vector<double> moves;
  for (const auto* clip : clips) {
    for (int64_t f = 1; f < clip->frame_count(); ++f) moves.push_back(pose_distance(clip->frame(f - 1), clip->frame(f), clip->columns));
  }
  std::nth_element(moves.begin(), moves.begin() + moves.size() / 2, moves.end());
  return moves[moves.size() / 2];
}

class JoinClipsService : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!test::has_h36m()) return;
    try {
      server_ = new test::ServerProcess();
      stub_ = v1::MotionManifold::NewStub(grpc::CreateChannel(server_->grpc_target(), grpc::InsecureChannelCredentials()))
                  .release();
      a_rows_ = new MotionFrames(s5_rows("walking_1.txt", kClipRows));
      b_rows_ = new MotionFrames(s5_rows("sitting_1.txt", kClipRows));
    } catch (const std::exception& e) {
      start_error_ = new std::string(e.what());
    }
  }
  static void TearDownTestSuite() {
    delete stub_;
    delete server_;
    delete a_rows_;
    delete b_rows_;
    delete start_error_;
    stub_ = nullptr;
    server_ = nullptr;
    a_rows_ = b_rows_ = nullptr;
    start_error_ = nullptr;
  }
  void SetUp() override {
    MM_REQUIRE_H36M();
    if (start_error_ != nullptr) FAIL() << *start_error_;
  }

  static v1::JoinClipsRequest request(const std::string& method, double seconds = 1) {
    v1::JoinClipsRequest r;
    *r.mutable_a() = wire_motion(*a_rows_, 50);
    *r.mutable_b() = wire_motion(*b_rows_, 50);
    r.set_transition_seconds(seconds);
    r.set_method(method);
    return r;
  }
  static grpc::Status join(const v1::JoinClipsRequest& r, v1::JoinClipsReply* reply, grpc::ClientContext* context) {
    // The generated transition's fit is 5 to 10 s of CPU; a busy machine
    // may take minutes of wall time for it.
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(600));
    const auto started = std::chrono::steady_clock::now();
    const auto status = stub_->JoinClips(context, r, reply);
    std::printf("JoinClips %s: %.2f s\n", r.method().c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    return status;
  }
  static std::string error_field(const grpc::ClientContext& context) {
    const auto& trailing = context.GetServerTrailingMetadata();
    const auto found = trailing.find("mm-error-field");
    return found == trailing.end() ? "(none)" : std::string(found->second.data(), found->second.size());
  }

  // The jumps into and out of the transition under 1.5x the clips' median
  // per-frame move.
  static void expect_borders_met(const MotionFrames& joined, int64_t first, int64_t last, const std::string& what) {
    const MotionFrames a = at_25hz(*a_rows_), b = at_25hz(*b_rows_);
    const double median = median_move({&a, &b});
    const double into = pose_distance(joined.frame(first - 1), joined.frame(first), joined.columns);
    const double out_of = pose_distance(joined.frame(last), joined.frame(last + 1), joined.columns);
    EXPECT_LT(into, 1.5 * median) << what << ": the jump into the transition against the clips' median move";
    EXPECT_LT(out_of, 1.5 * median) << what << ": the jump out of the transition against the clips' median move";
    std::printf("%s: median move %.4f rad, border jumps %.4f and %.4f rad\n", what.c_str(), median, into, out_of);
  }

  // Clip a's frames before the transition and b's after it, value for value.
  static void expect_clips_kept(const MotionFrames& joined, int64_t first, int64_t last, const std::string& what) {
    const MotionFrames a = at_25hz(*a_rows_), b = at_25hz(*b_rows_);
    ASSERT_EQ(first, a.frame_count() - kTransitionFrames) << what;
    ASSERT_EQ(last, a.frame_count() - 1) << what;
    ASSERT_EQ(joined.frame_count(), a.frame_count() + b.frame_count() - kTransitionFrames) << what;
    for (int64_t f = 0; f < first; ++f) {
      ASSERT_TRUE(std::equal(a.frame(f), a.frame(f) + a.columns, joined.frame(f))) << what << ": a's frame " << f;
    }
    for (int64_t f = last + 1; f < joined.frame_count(); ++f) {
      const int64_t in_b = f - first;
      ASSERT_TRUE(std::equal(b.frame(in_b), b.frame(in_b) + b.columns, joined.frame(f)))
          << what << ": b's frame " << in_b << " (joined frame " << f << ")";
    }
  }

  static test::ServerProcess* server_;
  static v1::MotionManifold::Stub* stub_;
  static MotionFrames* a_rows_;
  static MotionFrames* b_rows_;
  static std::string* start_error_;
};
test::ServerProcess* JoinClipsService::server_ = nullptr;
v1::MotionManifold::Stub* JoinClipsService::stub_ = nullptr;
MotionFrames* JoinClipsService::a_rows_ = nullptr;
MotionFrames* JoinClipsService::b_rows_ = nullptr;
std::string* JoinClipsService::start_error_ = nullptr;

TEST_F(JoinClipsService, GrpcKeepsBothClipsAndTheGeneratedTransitionMeetsThemUnlikeTheCrossfade) {
  v1::JoinClipsReply generated, crossfade;
  {
    grpc::ClientContext context;
    const auto status = join(request("generated"), &generated, &context);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  {
    grpc::ClientContext context;
    const auto status = join(request("crossfade"), &crossfade, &context);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_EQ(generated.answered_by().model(), "h36m-dkgm-h100");
  EXPECT_EQ(generated.motion().frame_rate(), 25);
  EXPECT_EQ(generated.motion().layout(), "h36m-expmap-99");
  EXPECT_EQ(generated.motion().root(), "input");
  const MotionFrames joined = frames_of(generated.motion());
  const MotionFrames faded = frames_of(crossfade.motion());
  const int64_t first = generated.transition_first_frame(), last = generated.transition_last_frame();
  expect_clips_kept(joined, first, last, "generated");
  expect_clips_kept(faded, crossfade.transition_first_frame(), crossfade.transition_last_frame(), "crossfade");

  expect_borders_met(joined, first, last, "generated over gRPC");
  double difference = 0;
  for (int64_t f = first; f <= last; ++f) difference = std::max(difference, pose_distance(joined.frame(f), faded.frame(f), joined.columns));
  EXPECT_GT(difference, 1e-2) << "the generated transition is the crossfade";
  std::printf("largest difference from the crossfade %.3f rad\n", difference);
}

TEST_F(JoinClipsService, GrpcRefusesBadInputNamingTheField) {
  struct Case {
    v1::JoinClipsRequest request;
    std::string field;
  };
  std::vector<Case> cases;
  cases.push_back({request("generated", 5), "transition_seconds"});
  cases.push_back({request("morph"), "method"});
  Case too_short{request("generated"), "a.frames"};
  MotionFrames short_rows = *a_rows_;
  short_rows.values.resize(static_cast<size_t>(60) * short_rows.columns);  // 30 frames at 25 Hz < 25 + 25
  *too_short.request.mutable_a() = wire_motion(short_rows, 50);
  cases.push_back(too_short);
  for (const auto& c : cases) {
    grpc::ClientContext context;
    v1::JoinClipsReply reply;
    const auto status = join(c.request, &reply, &context);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.field << ": " << status.error_message();
    EXPECT_EQ(error_field(context), c.field) << status.error_message();
    EXPECT_EQ(status.error_message().rfind(c.field + ": ", 0), 0u) << status.error_message();
  }
}

TEST_F(JoinClipsService, RestJoinsJsonMotionsAndTwoBvhFilesAndRefusesNamingTheField) {
  const json body = {{"a", motion_json(*a_rows_, 50)}, {"b", motion_json(*b_rows_, 50)}, {"transition_seconds", 1}};
  const auto started = std::chrono::steady_clock::now();
  const test::Reply reply = test::post(server_->rest_port(), "/v1/join", body);
  std::printf("POST /v1/join generated: %.2f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 400);
  const MotionFrames joined = frames_of(reply.document.at("motion"));
  const int64_t first = reply.document.at("transition_first_frame").get<int64_t>();
  const int64_t last = reply.document.at("transition_last_frame").get<int64_t>();
  expect_clips_kept(joined, first, last, "REST JSON");
  expect_borders_met(joined, first, last, "generated over REST");

  // The same clips as BVH files, two parts of one multipart/form-data body.
  httplib::MultipartFormDataItems parts = {
      {"a", h36m_motion_to_bvh_text(*a_rows_, 50), "walking.bvh", "application/octet-stream"},
      {"b", h36m_motion_to_bvh_text(*b_rows_, 50), "sitting.bvh", "application/x-bvh"},
      {"transition_seconds", "1", "", ""},
      {"method", "crossfade", "", ""},
  };
  auto client = test::rest_client(server_->rest_port());
  const test::Reply files = test::to_reply(client.Post("/v1/join", parts));
  ASSERT_EQ(files.status, 200) << files.body.substr(0, 400);
  const MotionFrames from_files = frames_of(files.document.at("motion"));
  EXPECT_EQ(from_files.frame_count(), joined.frame_count());
  EXPECT_EQ(files.document.at("transition_first_frame").get<int64_t>(), first);
  // BVH holds Euler angles: the clip's frames come back through them, near.
  const MotionFrames a = at_25hz(*a_rows_);
  double bvh_worst = 0;
  for (int64_t f = 0; f < first; ++f) bvh_worst = std::max(bvh_worst, pose_distance(a.frame(f), from_files.frame(f), a.columns));
  EXPECT_LT(bvh_worst, 1e-3) << "clip a's frames read from its BVH file";

  // Refusals name the field, as over gRPC.
  json too_long = body;
  too_long["transition_seconds"] = 5;
  const test::Reply refused = test::post(server_->rest_port(), "/v1/join", too_long);
  EXPECT_EQ(refused.status, 400) << refused.body;
  EXPECT_EQ(refused.field(), "transition_seconds") << refused.body;
  json unknown = body;
  unknown["method"] = "morph";
  const test::Reply unknown_method = test::post(server_->rest_port(), "/v1/join", unknown);
  EXPECT_EQ(unknown_method.status, 400) << unknown_method.body;
  EXPECT_EQ(unknown_method.field(), "method") << unknown_method.body;
  MotionFrames short_rows = *b_rows_;
  short_rows.values.resize(static_cast<size_t>(60) * short_rows.columns);
  json too_short = body;
  too_short["b"] = motion_json(short_rows, 50);
  const test::Reply short_clip = test::post(server_->rest_port(), "/v1/join", too_short);
  EXPECT_EQ(short_clip.status, 400) << short_clip.body;
  EXPECT_EQ(short_clip.field(), "b.frames") << short_clip.body;
}

}  // namespace
}  // namespace mm
