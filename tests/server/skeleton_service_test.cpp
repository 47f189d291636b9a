// A user's own skeleton through the service, end to end on the real server
// over REST: a training job on a folder of CMU dance BVH files (43 joints,
// cm, 120 Hz) prepares and trains a small manifold of that skeleton and
// publishes it; activated, it encodes BVH of that skeleton, decodes and
// samples BVH of the same hierarchy, interpolates in its layout, and refuses
// a BVH of another hierarchy or a malformed one naming what is wrong. The
// tool decodes with the published model into BVH of the same rig too, and
// the command-line client reads and writes BVH and text of that rig over
// either protocol, as REST converts them. A job on a folder of Blender's
// glTF exports of dances publishes a model of the same rig, in mm.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/motion_text.h"
#include "tests/common/blender_dances.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ::testing::HasSubstr;

// The first 6 s of a CMU file (720 frames at 120 Hz: 150 at 25 Hz, the
// model's clip) as BVH text, the hierarchy unchanged.
std::string six_seconds(const std::string& relative) {
  BvhFile file = read_bvh_file((cmu_dance_dir() / relative).string());
  file.values.resize(static_cast<size_t>(720) * file.channel_count());
  return write_bvh_text(file);
}

// The REST calls of these tests, to one server.
class Rest {
 public:
  explicit Rest(const ServerProcess& server) : port_(server.rest_port()) {}
  test::Reply post(const std::string& path, const std::string& body, const std::string& type,
                   const std::string& accept = "application/json") {
    return test::post(port_, path, body, {{"Accept", accept}}, type);
  }
  json post_json(const std::string& path, const json& body) {
    const test::Reply reply = test::post(port_, path, body);
    EXPECT_EQ(reply.status, 200) << path << ": " << reply.body;
    return reply.document;
  }
  json get(const std::string& path) { return test::get(port_, path).document; }

 private:
  int port_;
};

// The hierarchy of a BVH reply is the CMU rig's: names, parents, End Sites,
// channels and offsets (cm); 150 frames at 25 Hz.
void expect_cmu_rig(const std::string& text, const BvhFile& rig) {
  const BvhFile file = parse_bvh_text(text, "reply.bvh");
  ASSERT_EQ(file.joints.size(), rig.joints.size());
  for (size_t j = 0; j < rig.joints.size(); ++j) {
    EXPECT_EQ(file.joints[j].name, rig.joints[j].name);
    EXPECT_EQ(file.joints[j].parent, rig.joints[j].parent);
    EXPECT_EQ(file.joints[j].end_site, rig.joints[j].end_site);
    EXPECT_EQ(file.joints[j].channels, rig.joints[j].channels) << rig.joints[j].name;
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(file.joints[j].offset[a], rig.joints[j].offset[a], 1e-5);
  }
  EXPECT_EQ(file.frame_count(), 150);
  EXPECT_NEAR(file.frame_time_s, 0.04, 1e-9);
  for (double value : file.values) ASSERT_TRUE(std::isfinite(value));
}

// The root's horizontal path length and mean height over a BVH's frames, in
// the file's unit, from its root position channels.
struct RootTravel {
  double path_length = 0, mean_height = 0;
};
RootTravel root_travel(const BvhFile& file) {
  const auto& channels = file.joints.at(0).channels;
  auto index = [&](BvhChannel channel) {
    const auto at = std::find(channels.begin(), channels.end(), channel);
    EXPECT_NE(at, channels.end()) << bvh_channel_name(channel);
    return static_cast<int>(at - channels.begin());
  };
  const int x = index(BvhChannel::kXposition), y = index(BvhChannel::kYposition), z = index(BvhChannel::kZposition);
  RootTravel travel;
  const int stride = file.channel_count();
  for (int64_t f = 0; f < file.frame_count(); ++f) {
    const double* frame = file.values.data() + f * stride;
    travel.mean_height += frame[y] / static_cast<double>(file.frame_count());
    if (f > 0) travel.path_length += std::hypot(frame[x] - frame[x - stride], frame[z] - frame[z - stride]);
  }
  return travel;
}

// Three CMU dances in `folder`: indian/04.bvh, indian/06.bvh, martial/03.bvh.
void copy_three_dances(const fs::path& folder) {
  for (const char* file : {"indian/04.bvh", "indian/06.bvh", "martial/03.bvh"}) {
    fs::create_directories((folder / file).parent_path());
    fs::copy_file(cmu_dance_dir() / file, folder / file);
  }
}

// A data root holding three CMU dances under dances/.
fs::path dance_data_root(const ScratchDir& scratch) {
  const fs::path root = scratch.path() / "data";
  copy_three_dances(root / "dances");
  return root;
}

// A server that trains jobs on `data_root`, with its state in `scratch`.
// Its jobs train on one thread: ctest runs two suites at once on two
// cores, and a child's two OpenMP threads spinning beside the other suite
// slowed this suite from 20 s alone to 241 s in a full run.
std::vector<std::string> job_server_args(const ScratchDir& scratch, const fs::path& data_root) {
  fs::create_directories(data_root);
  return {"--state-dir", (scratch.path() / "state").string(), "--data-root", data_root.string(), "--training-threads", "1"};
}

// Trains a tiny manifold of the dances under `dataset` (dances/) of the data
// root through a job and publishes it as `model_name` ("dances"), not
// activated.
void train_dances_model(Rest& rest, const ServerProcess& server, const std::string& dataset = "dances",
                        const std::string& model_name = "dances") {
  const json job = rest.post_json("/v1/jobs", {{"dataset", dataset}, {"variant", "DKGM"}, {"iterations", 3},
                                               {"hidden", 16}, {"batch", 2}, {"seed", 1}, {"model_name", model_name}});
  const std::string id = job.value("id", "");
  json record;
  for (int i = 0; i < 300 * 5; ++i) {
    record = rest.get("/v1/jobs/" + id);
    const std::string state = record.value("state", "");
    if (state == "succeeded" || state == "failed" || state == "cancelled") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_EQ(record.value("state", ""), "succeeded") << record.dump() << "\n" << server.log();
  EXPECT_EQ(record["published_model"], model_name);
}

TEST(SkeletonService, AJobOnABvhFolderPublishesAModelThatSpeaksBvhOfThatSkeleton) {
  ScratchDir scratch;
  ServerProcess server(job_server_args(scratch, dance_data_root(scratch)));
  Rest rest(server);

  // A folder that is not under the data root, or holds one file, is refused
  // at submission.
  auto refused = rest.post("/v1/jobs", json{{"dataset", "dances/martial"}}.dump(), "application/json");
  ASSERT_NE(refused.status, 0);
  EXPECT_EQ(refused.status, 400);
  EXPECT_THAT(refused.body, HasSubstr("holds one animation file (03.bvh), expected at least two"));

  train_dances_model(rest, server);
  if (HasFatalFailure()) return;

  const json activated = rest.post_json("/v1/models/dances:activate", json::object());
  EXPECT_TRUE(activated.value("active", false)) << activated.dump();
  EXPECT_EQ(activated["columns"], 3 + 3 * 57);  // 43 joints and 14 End Sites
  EXPECT_EQ(activated["layout"], "expmap-174");

  // Encode: BVH of the CMU rig in, a code out.
  const BvhFile rig = read_bvh_file((cmu_dance_dir() / "martial/03.bvh").string());
  auto encoded = rest.post("/v1/encode", six_seconds("martial/03.bvh"), "application/x-bvh");
  ASSERT_NE(encoded.status, 0);
  ASSERT_EQ(encoded.status, 200) << encoded.body;
  const json code = json::parse(encoded.body)["codes"][0];
  ASSERT_EQ(code.size(), 64u);
  auto other = rest.post("/v1/encode", six_seconds("indian/06.bvh"), "application/x-bvh");
  ASSERT_NE(other.status, 0);
  ASSERT_EQ(other.status, 200) << other.body;
  const json other_code = json::parse(other.body)["codes"][0];
  EXPECT_NE(code, other_code);

  // Decode and sample: BVH of the same hierarchy back.
  auto decoded = rest.post("/v1/decode", json{{"codes", {code}}}.dump(), "application/json", "application/x-bvh");
  ASSERT_NE(decoded.status, 0);
  ASSERT_EQ(decoded.status, 200) << decoded.body;
  EXPECT_EQ(decoded.header("Content-Type"), "application/x-bvh");
  expect_cmu_rig(decoded.body, rig);
  auto sampled = rest.post("/v1/sample", json{{"count", 1}, {"seed", 7}}.dump(), "application/json", "application/x-bvh");
  ASSERT_NE(sampled.status, 0);
  ASSERT_EQ(sampled.status, 200) << sampled.body;
  expect_cmu_rig(sampled.body, rig);

  // The job trained the rig's root path too: what the model makes travels,
  // its root in the rig's own channels and unit (cm: the hips stand about
  // as high as in the recording, not ten times higher).
  EXPECT_EQ(activated["trajectory"], true) << activated.dump();
  const RootTravel recorded = root_travel(parse_bvh_text(six_seconds("martial/03.bvh"), "martial/03.bvh"));
  for (const std::string& reply : {decoded.body, sampled.body}) {
    const RootTravel generated = root_travel(parse_bvh_text(reply, "reply.bvh"));
    std::printf("root path over 6 s: %.1f cm generated (hips %.1f cm high), %.1f cm recorded (hips %.1f cm)\n",
                generated.path_length, generated.mean_height, recorded.path_length, recorded.mean_height);
    EXPECT_GT(generated.path_length, 10.0) << "the generated dance stands in place";
    EXPECT_GT(generated.mean_height, 0.5 * recorded.mean_height);
    EXPECT_LT(generated.mean_height, 2.0 * recorded.mean_height);
  }
  // A decoded BVH encodes again: the reply is a valid motion of the skeleton.
  auto again = rest.post("/v1/encode", decoded.body, "application/x-bvh");
  ASSERT_NE(again.status, 0);
  EXPECT_EQ(again.status, 200) << again.body;

  // Interpolate between the two codes: motions in the model's layout.
  const json path = rest.post_json(
      "/v1/interpolate", {{"from", {{"code", code}}}, {"to", {{"code", other_code}}}, {"steps", 3}, {"method", "spherical"}});
  ASSERT_EQ(path["motions"].size(), 3u);
  for (const auto& motion : path["motions"]) {
    EXPECT_EQ(motion["layout"], "expmap-174");
    EXPECT_EQ(motion["columns"], 174);
    EXPECT_EQ(motion["frames"], 150);
  }
  // Any one of them as BVH of the rig.
  auto middle = rest.post("/v1/decode", json{{"codes", {path["codes"][1]}}}.dump(), "application/json",
                          "application/x-bvh");
  ASSERT_NE(middle.status, 0);
  expect_cmu_rig(middle.body, rig);

  // Another hierarchy (H3.6M's) and a malformed BVH are refused, naming why.
  MotionFrames h36m;
  h36m.values.assign(150 * kH36mColumns, 0.0f);
  auto wrong = rest.post("/v1/encode", h36m_motion_to_bvh_text(h36m, 25), "application/x-bvh");
  ASSERT_NE(wrong.status, 0);
  EXPECT_EQ(wrong.status, 400);
  EXPECT_THAT(wrong.body, HasSubstr("not the skeleton \\\"dances\\\": it has 25 joints and 7 end sites"));
  EXPECT_THAT(wrong.body, HasSubstr("missing joints: hip"));
  std::string broken = six_seconds("martial/03.bvh");
  broken.replace(broken.find("CHANNELS 3"), 10, "CHANNELS 9");
  auto malformed = rest.post("/v1/encode", broken, "application/x-bvh");
  ASSERT_NE(malformed.status, 0);
  EXPECT_EQ(malformed.status, 400);
  EXPECT_THAT(malformed.body, HasSubstr("request body:9: channel count 9, expected 0 to 6"));
  // An H3.6M motion as JSON: the layout names the model's.
  auto h36m_json = rest.post("/v1/encode",
                             json{{"motions", {{{"frames", 150}, {"columns", 99}, {"frame_rate", 25},
                                                {"layout", "h36m-expmap-99"}, {"values", h36m.values}}}}}.dump(),
                             "application/json");
  ASSERT_NE(h36m_json.status, 0);
  EXPECT_EQ(h36m_json.status, 400);
  EXPECT_THAT(h36m_json.body, HasSubstr("expected \\\"expmap-174\\\""));

  // The tool with the published model: a code file to BVH of the rig.
  const std::string code_file = scratch.file("code.json");
  std::ofstream(code_file) << code.dump();
  const std::string out = scratch.file("decoded.bvh");
  const std::string command = std::string(MM_TOOL_PATH) + " decode --model '" +
                              (fs::path(server.model_store()) / "dances").string() + "' --code '" + code_file +
                              "' --out '" + out + "' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(out);
  expect_cmu_rig(std::string(std::istreambuf_iterator<char>(in), {}), rig);
}

// A job on a data-root folder of .glb files (Blender's exports of three
// dances, blender_dances.h): the job prepares it as it does BVH, and the
// model it publishes has the rig's skeleton, in mm (glTF carries metres),
// and reconstructs a .glb take of it.
TEST(SkeletonService, AJobOnAGlbFolderPublishesAModelOfThatSkeletonInMillimetres) {
  const test::BlenderDances& dances = blender_dances();
  ScratchDir scratch;
  const fs::path data_root = scratch.path() / "data";
  fs::create_directories(data_root);
  fs::copy(dances.glb, data_root / "glb-dances", fs::copy_options::recursive);
  ServerProcess server(job_server_args(scratch, data_root));
  Rest rest(server);
  const auto started = std::chrono::steady_clock::now();
  train_dances_model(rest, server, "glb-dances", "glb-dances");
  if (HasFatalFailure()) return;
  std::printf("job on 3 glb files (3 iterations, its root path 100): %.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());

  // Blender drops the End Sites: the rig's 43 joints.
  const json activated = rest.post_json("/v1/models/glb-dances:activate", json::object());
  EXPECT_EQ(activated["columns"], 3 + 3 * 43) << activated.dump();
  EXPECT_EQ(activated["layout"], "expmap-132");

  // A glb take in, BVH of the rig out: the CMU joints with their parents and
  // bone offsets in mm (the recording's cm times 10), at the take's 60 Hz.
  const std::string take = read_text((dances.glb / "martial/03.glb").string());
  auto reply = rest.post("/v1/takes:reconstruct", take, "model/gltf-binary", "application/x-bvh");
  ASSERT_NE(reply.status, 0);
  ASSERT_EQ(reply.status, 200) << reply.body;
  const BvhFile got = parse_bvh_text(reply.body, "reply.bvh");
  const BvhFile recording = read_bvh_file((dances.bvh / "martial/03.bvh").string());
  EXPECT_EQ(got.named_joint_count(), recording.named_joint_count());
  EXPECT_EQ(got.frame_count(), recording.frame_count());
  EXPECT_NEAR(got.frame_time_s, recording.frame_time_s, 1e-6);
  auto parent_name = [](const BvhFile& file, const BvhJoint& joint) {
    return joint.parent < 0 ? std::string() : file.joints[joint.parent].name;
  };
  for (const BvhJoint& joint : recording.joints) {
    if (joint.end_site) continue;
    const auto found = std::find_if(got.joints.begin(), got.joints.end(),
                                    [&](const BvhJoint& j) { return !j.end_site && j.name == joint.name; });
    if (found == got.joints.end()) {
      ADD_FAILURE() << "no joint " << joint.name;
      continue;
    }
    EXPECT_EQ(parent_name(got, *found), parent_name(recording, joint)) << joint.name;
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(found->offset[a], joint.offset[a] * 10, 0.01) << joint.name;
  }
  for (double value : got.values) ASSERT_TRUE(std::isfinite(value));
  // Its root about as high as the recording's (mm, not cm or m).
  const RootTravel recorded = root_travel(recording), generated = root_travel(got);
  std::printf("hips %.0f mm high reconstructed, %.0f mm recorded\n", generated.mean_height,
              recorded.mean_height * 10);
  EXPECT_GT(generated.mean_height, 0.5 * recorded.mean_height * 10);
  EXPECT_LT(generated.mean_height, 2.0 * recorded.mean_height * 10);
}

// The sum of the metric lines `name{...}` holding every one of `labels`.
double metric_sum(const std::string& text, const std::string& name, const std::vector<std::string>& labels) {
  double sum = 0;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind(name + "{", 0) != 0) continue;
    bool all = true;
    for (const auto& label : labels) all = all && line.find(label) != std::string::npos;
    if (all) sum += std::stod(line.substr(line.rfind(' ') + 1));
  }
  return sum;
}

// BVH requests to the active model while it is switched, over and over,
// between two models of different rigs (H3.6M's and one trained on the CMU
// dances): each request is read and answered by one model. A BVH body is
// either taken by the model of its rig, which answers, or refused by the
// other model's skeleton as not its own; it is never read for one model and
// handed to the other (whose core would refuse its columns or layout, or
// answer for the wrong rig). A take's reply names the model whose columns and
// layout it has; a BVH reply is one rig's, whole. A BVH request naming an
// unknown model, or with a body that does not parse, gets the call's error
// and is counted in the metrics as every call is (the drain: core_tests'
// ACallReadForItsModelIsRefusedAndCountedAsEveryCall).
TEST(SkeletonService, BvhRequestsRacingActivationsAreReadAndAnsweredByOneModel) {
  ScratchDir scratch;
  ServerProcess server(job_server_args(scratch, dance_data_root(scratch)));
  Rest rest(server);
  train_dances_model(rest, server);
  if (HasFatalFailure()) return;
  const int port = server.rest_port();
  const std::string h36m_model = "h36m-dkgm-cpu";
  rest.post_json("/v1/models/" + h36m_model + ":activate", json::object());

  MotionFrames h36m;
  h36m.values.assign(150 * kH36mColumns, 0.0f);
  for (size_t i = 0; i < h36m.values.size(); ++i) h36m.values[i] = 0.05f * static_cast<float>(i % 7);
  const std::string h36m_bvh = h36m_motion_to_bvh_text(h36m, 25);
  const std::string dance_bvh = six_seconds("martial/03.bvh");
  const size_t h36m_joints = parse_bvh_text(h36m_bvh, "h36m.bvh").joints.size();
  const size_t dance_joints = parse_bvh_text(dance_bvh, "dance.bvh").joints.size();
  ASSERT_NE(h36m_joints, dance_joints);

  // An encode of `body`: answered by `own` model, or refused as not the
  // other model's skeleton (`refusal`).
  const auto check_encode = [&](const std::string& body, const std::string& own, const std::string& refusal) {
    const test::Reply reply = test::post(port, "/v1/encode", body, {}, "application/x-bvh");
    if (reply.status == 200) {
      EXPECT_EQ(json::parse(reply.body)["answered_by"]["model"], own) << reply.body;
    } else {
      EXPECT_EQ(reply.status, 400) << reply.body;
      EXPECT_THAT(reply.body, HasSubstr(refusal));
    }
  };
  std::atomic<bool> requesting{true};
  std::atomic<int> activations{0};
  std::thread activator([&] {
    for (int i = 1; requesting; ++i) {
      const std::string name = i % 2 == 1 ? "dances" : h36m_model;
      const test::Reply reply = test::post(port, "/v1/models/" + name + ":activate", std::string("{}"));
      EXPECT_EQ(reply.status, 200) << reply.body;
      ++activations;
    }
  });
  std::vector<std::thread> requesters;
  for (int t = 0; t < 2; ++t) {
    requesters.emplace_back([&] {
      for (int round = 0; round < 8; ++round) {
        check_encode(h36m_bvh, h36m_model, "not the skeleton \\\"dances\\\"");
        check_encode(dance_bvh, "dances", "not the H3.6M skeleton");
        // A take of the dance, its reply as JSON: the model it names is the
        // one whose columns and layout the reply has.
        const test::Reply take = test::post(port, "/v1/takes:reconstruct", dance_bvh,
                                            {{"Accept", "application/json"}}, "application/x-bvh");
        if (take.status == 200) {
          const json reply = json::parse(take.body);
          EXPECT_EQ(reply["answered_by"]["model"], "dances");
          EXPECT_EQ(reply["columns"], 174);
          EXPECT_EQ(reply["layout"], "expmap-174");
        } else {
          EXPECT_EQ(take.status, 400) << take.body;
          EXPECT_THAT(take.body, HasSubstr("not the H3.6M skeleton"));
        }
        // A decode as BVH: one rig's hierarchy, 150 frames.
        const test::Reply decoded = test::post(port, "/v1/decode", json{{"codes", {std::vector<float>(64, 0.1f)}}}.dump(),
                                               {{"Accept", "application/x-bvh"}}, "application/json");
        ASSERT_EQ(decoded.status, 200) << decoded.body;
        const BvhFile file = parse_bvh_text(decoded.body, "reply.bvh");
        EXPECT_TRUE(file.joints.size() == h36m_joints || file.joints.size() == dance_joints) << file.joints.size();
        EXPECT_EQ(file.frame_count(), 150);
      }
    });
  }
  for (auto& requester : requesters) requester.join();
  requesting = false;
  activator.join();
  EXPECT_GE(activations.load(), 4) << "the activations did not race the requests";

  // An unknown model and a malformed body: the call's error, counted.
  const std::string before = test::get(port, "/metrics").body;
  const test::Reply unknown = test::post(port, "/v1/encode?model=nobody", dance_bvh, {}, "application/x-bvh");
  EXPECT_EQ(unknown.status, 404) << unknown.body;
  EXPECT_THAT(unknown.body, HasSubstr("NOT_FOUND"));
  const test::Reply unknown_take =
      test::post(port, "/v1/takes:reconstruct?model=nobody", dance_bvh, {}, "application/x-bvh");
  EXPECT_EQ(unknown_take.status, 404) << unknown_take.body;
  std::string broken = dance_bvh;
  broken.replace(broken.find("CHANNELS 3"), 10, "CHANNELS 9");
  const test::Reply malformed = test::post(port, "/v1/encode?model=dances", broken, {}, "application/x-bvh");
  EXPECT_EQ(malformed.status, 400) << malformed.body;
  EXPECT_THAT(malformed.body, HasSubstr("request body:9: channel count 9, expected 0 to 6"));
  const std::string after = test::get(port, "/metrics").body;
  const auto counted = [&](const std::string& operation, const std::string& code) {
    const std::vector<std::string> labels{"code=\"" + code + "\"", "operation=\"" + operation + "\"",
                                          "protocol=\"rest\""};
    return metric_sum(after, "mm_requests_total", labels) - metric_sum(before, "mm_requests_total", labels);
  };
  EXPECT_EQ(counted("encode", "NOT_FOUND"), 1) << after;
  EXPECT_EQ(counted("reconstruct_take", "NOT_FOUND"), 1) << after;
  EXPECT_EQ(counted("encode", "INVALID_ARGUMENT"), 1) << after;
}

// The command-line client with a model of the user's rig: the user's BVH
// files uploaded with it and trained on; it asks the server for the model's
// skeleton and converts BVH and text of that rig as REST does, over either
// protocol, named with --model or active.
TEST(SkeletonService, TheClientReadsAndWritesBvhAndTextOfTheModelsRigOverEitherProtocol) {
  ScratchDir scratch;
  const fs::path root = scratch.path() / "data";
  ServerProcess server(job_server_args(scratch, root));
  Rest rest(server);
  const auto client = [&](const std::string& arguments) { return run_command(MM_CLIENT_PATH, arguments); };
  const std::vector<std::string> protocols{"--server " + server.grpc_target(), "--rest --rest-url " + server.rest_url()};

  // The user's files go under the data root with the client, then train.
  const fs::path mine = scratch.path() / "my-mocap";
  copy_three_dances(mine);
  const CommandRun uploaded = client(protocols[0] + " clips upload " + mine.string() + " --to dances");
  ASSERT_EQ(uploaded.exit_code, 0) << uploaded.err;
  EXPECT_THAT(uploaded.out, HasSubstr("dances/martial/03.bvh"));
  for (const char* file : {"indian/04.bvh", "indian/06.bvh", "martial/03.bvh"}) {
    EXPECT_EQ(read_text((root / "dances" / file).string()), read_text((mine / file).string())) << file;
  }
  const CommandRun again =
      client(protocols[1] + " clips upload " + (mine / "indian" / "04.bvh").string() + " --to dances/indian");
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_THAT(again.err, HasSubstr("error: FAILED_PRECONDITION: path: path \"dances/indian/04.bvh\" exists already"));
  const CommandRun missing = client(protocols[1] + " clips upload " + (mine / "nothing").string() + " --to dances");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.err, HasSubstr("no such file or folder"));
  train_dances_model(rest, server);
  if (HasFatalFailure()) return;

  // The description carries the rig: 57 joints, cm, the BVH channels.
  const CommandRun described = client(protocols[0] + " --json models describe dances");
  ASSERT_EQ(described.exit_code, 0) << described.err;
  const json skeleton = json::parse(described.out)["skeleton"];
  EXPECT_EQ(skeleton["name"], "dances");
  EXPECT_EQ(skeleton["joints"].size(), 57u);
  EXPECT_EQ(skeleton["bvh"]["millimetres_per_unit"], 10);

  // Encode: the code REST gives for the same BVH body, while the H3.6M model
  // is the active one (--model dances), then with dances active.
  const std::string dance = scratch.write("dance.bvh", six_seconds("martial/03.bvh"));
  const auto rest_code = [&](const std::string& model) {
    const test::Reply reply = rest.post("/v1/encode" + model, read_text(dance), "application/x-bvh");
    EXPECT_EQ(reply.status, 200) << reply.body;
    return json::parse(reply.body)["codes"][0].get<std::vector<double>>();
  };
  const auto expect_code = [](const CommandRun& run, const std::vector<double>& want, double tolerance = 1e-5) {
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto code = json::parse(run.out)["codes"][0].get<std::vector<double>>();  // the one code-file shape
    ASSERT_EQ(code.size(), want.size());
    for (size_t i = 0; i < code.size(); ++i) EXPECT_NEAR(code[i], want[i], tolerance) << i;
    EXPECT_EQ(json::parse(run.out)["model"], "dances");
  };
  const std::vector<double> want = rest_code("?model=dances");
  ASSERT_EQ(want.size(), 64u);
  for (const auto& protocol : protocols) {
    SCOPED_TRACE(protocol + ", --model dances");
    expect_code(client(protocol + " encode --model dances --input " + dance), want);
  }
  rest.post_json("/v1/models/dances:activate", json::object());
  for (const auto& protocol : protocols) {
    SCOPED_TRACE(protocol + ", dances active");
    expect_code(client(protocol + " encode --input " + dance), want);
  }

  // Decode: byte for byte the BVH REST answers for the same code, of the
  // CMU rig; text of its 174 columns, which reads back at 25 Hz.
  const std::string code_file = scratch.write("code.json", json{{"code", want}}.dump());
  const test::Reply rest_bvh =
      rest.post("/v1/decode", json{{"codes", {want}}}.dump(), "application/json", "application/x-bvh");
  ASSERT_EQ(rest_bvh.status, 200) << rest_bvh.body;
  const BvhFile rig = read_bvh_file((cmu_dance_dir() / "martial/03.bvh").string());
  for (const auto& protocol : protocols) {
    SCOPED_TRACE(protocol + ", decode");
    const std::string out = scratch.file("decoded.bvh");
    const CommandRun decoded = client(protocol + " decode --code " + code_file + " --out " + out);
    ASSERT_EQ(decoded.exit_code, 0) << decoded.err;
    EXPECT_EQ(read_text(out), rest_bvh.body);
    expect_cmu_rig(read_text(out), rig);
    const std::string text = scratch.file("decoded.txt");
    ASSERT_EQ(client(protocol + " decode --code " + code_file + " --out " + text).exit_code, 0);
    const MotionFrames rows = read_motion_text(text, 174);
    EXPECT_EQ(rows.frame_count(), 150);
    const CommandRun from_text = client(protocol + " encode --rate 25 --input " + text);
    const CommandRun from_bvh = client(protocol + " encode --input " + out);
    ASSERT_EQ(from_text.exit_code, 0) << from_text.err;
    ASSERT_EQ(from_bvh.exit_code, 0) << from_bvh.err;
    // BVH holds Euler angles in degrees with a few decimals: near, not equal.
    expect_code(from_bvh, json::parse(from_text.out)["codes"][0].get<std::vector<double>>(), 1e-3);
  }

  // Samples as BVH files of the rig: one is REST's sample of the same seed
  // byte for byte; of two (decoded as one batch, so equal to rounding only)
  // each is a motion of the rig.
  const test::Reply rest_sample =
      rest.post("/v1/sample", json{{"count", 1}, {"seed", 7}}.dump(), "application/json", "application/x-bvh");
  ASSERT_EQ(rest_sample.status, 200) << rest_sample.body;
  for (const auto& protocol : protocols) {
    SCOPED_TRACE(protocol + ", sample");
    const fs::path dir = scratch.path() / "samples";
    fs::remove_all(dir);
    const auto sample = [&](int count) {
      return client(protocol + " sample --count " + std::to_string(count) + " --seed 7 --out-dir " + dir.string() +
                    " --format bvh");
    };
    const CommandRun one = sample(1);
    ASSERT_EQ(one.exit_code, 0) << one.err;
    EXPECT_EQ(read_text((dir / "sample_000.bvh").string()), rest_sample.body);
    const CommandRun two = sample(2);
    ASSERT_EQ(two.exit_code, 0) << two.err;
    for (const char* name : {"sample_000.bvh", "sample_001.bvh"}) expect_cmu_rig(read_text((dir / name).string()), rig);
  }

  // Another hierarchy (H3.6M's) is refused locally, naming what differs; so
  // is text of H3.6M's 99 columns.
  MotionFrames h36m;
  h36m.values.assign(150 * kH36mColumns, 0.0f);
  const CommandRun wrong = client(protocols[0] + " encode --input " +
                                  scratch.write("h36m.bvh", h36m_motion_to_bvh_text(h36m, 25)));
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_THAT(wrong.err, HasSubstr("not the skeleton \"dances\": it has 25 joints and 7 end sites"));
  const CommandRun text_99 = client(protocols[1] + " encode --rate 25 --input " +
                                    (h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  EXPECT_EQ(text_99.exit_code, 2);
  EXPECT_THAT(text_99.err, HasSubstr("walking_1.txt:1"));
}

}  // namespace
}  // namespace mm::test
