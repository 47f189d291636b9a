// Clips of the data root through the real server, over both protocols: a
// server started with --data-root on a small folder (copies of two H3.6M
// files and a BVH of the H3.6M skeleton) lists them alike over gRPC and
// REST, reads a window that is exactly every second row of the file from its
// start and encodes to the code of the raw 50 Hz rows, and refuses a path
// outside the root, a missing file, a start past the last full window and a
// malformed query naming the field; a server without --data-root answers
// FAILED_PRECONDITION (409) naming the flag. Uploads over both protocols
// write new files that are then listed and read, need the token, and are
// refused naming the field. A whole read (ReadClipRequest.whole, REST's
// GET /v1/clips/motion) is every row of the text file at 50 Hz, refused
// naming "start" for a nonzero start, naming "path" for a file longer
// than --max-take-seconds, and for a BVH of another skeleton in the words a
// take of it is refused in. Values a text marks missing (`nan`) are read
// as NaN, whole and in a window, over both protocols.
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <httplib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/motion_text.h"
#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::motionmanifold::v1;
using json = nlohmann::json;

const char* const kText = "h36m/S5/walking_1.txt";
const char* const kBvh = "bvh/walking.bvh";

// The data root: real copies (a link out of the root is not one of its
// clips) and a BVH of the first 400 rows of S5 walking at 50 Hz.
fs::path make_data_root(const fs::path& root) {
  for (const char* subject : {"S1", "S5"}) fs::create_directories(root / "h36m" / subject);
  fs::copy_file(test::h36m_dataset_dir() / "S5" / "walking_1.txt", root / kText);
  fs::copy_file(test::h36m_dataset_dir() / "S1" / "eating_1.txt", root / "h36m" / "S1" / "eating_1.txt");
  auto rows = read_motion_text((root / kText).string());
  rows.values.resize(400 * static_cast<size_t>(rows.columns));
  fs::create_directories(root / "bvh");
  write_bvh_file(h36m_motion_to_bvh(rows, 50), (root / kBvh).string());
  return root;
}

std::string error_field(const grpc::ClientContext& context) {
  const auto& trailing = context.GetServerTrailingMetadata();
  const auto found = trailing.find("mm-error-field");
  return found == trailing.end() ? "(none)" : std::string(found->second.data(), found->second.size());
}

// One server for the suite: loading the model is the slow part.
class ClipsService : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!test::has_h36m()) return;
    scratch_ = new test::ScratchDir();
    try {
      server_ = new test::ServerProcess({"--data-root", make_data_root(scratch_->path() / "data").string()});
      grpc::ChannelArguments arguments;
      arguments.SetMaxReceiveMessageSize(-1);
      stub_ = v1::MotionManifold::NewStub(
                  grpc::CreateCustomChannel(server_->grpc_target(), grpc::InsecureChannelCredentials(), arguments))
                  .release();
    } catch (const std::exception& e) {
      start_error_ = new std::string(e.what());
    }
  }
  static void TearDownTestSuite() {
    delete stub_;
    delete server_;
    delete scratch_;
    delete start_error_;
    stub_ = nullptr;
    server_ = nullptr;
    scratch_ = nullptr;
    start_error_ = nullptr;
  }
  void SetUp() override {
    MM_REQUIRE_H36M();
    if (start_error_ != nullptr) FAIL() << *start_error_;
  }

  static grpc::Status read_clip(const std::string& path, int64_t start, v1::ReadClipReply* reply,
                                grpc::ClientContext* context, bool whole = false) {
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
    v1::ReadClipRequest request;
    request.set_path(path);
    request.set_start(start);
    request.set_whole(whole);
    return stub_->ReadClip(context, request, reply);
  }
  static std::vector<float> encode(const v1::Motion& motion) {
    grpc::ClientContext context;
    v1::EncodeRequest request;
    *request.add_motions() = motion;
    v1::EncodeReply reply;
    const auto status = stub_->Encode(&context, request, &reply);
    EXPECT_TRUE(status.ok()) << status.error_message();
    if (reply.codes_size() != 1) return {};
    return {reply.codes(0).values().begin(), reply.codes(0).values().end()};
  }
  static fs::path data_root() { return scratch_->path() / "data"; }
  static int port() { return server_->rest_port(); }

  static test::ScratchDir* scratch_;
  static test::ServerProcess* server_;
  static v1::MotionManifold::Stub* stub_;
  static std::string* start_error_;
};
test::ScratchDir* ClipsService::scratch_ = nullptr;
test::ServerProcess* ClipsService::server_ = nullptr;
v1::MotionManifold::Stub* ClipsService::stub_ = nullptr;
std::string* ClipsService::start_error_ = nullptr;

TEST_F(ClipsService, BothProtocolsListTheDataRootsFilesWithFormatAndSize) {
  grpc::ClientContext context;
  v1::ListClipsReply listed;
  const auto status = stub_->ListClips(&context, v1::ListClipsRequest(), &listed);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const test::Reply rest = test::get(port(), "/v1/clips");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_FALSE(listed.truncated());
  EXPECT_EQ(rest.document["truncated"], false);
  const std::vector<std::pair<std::string, std::string>> expected = {
      {kBvh, "bvh"}, {"h36m/S1/eating_1.txt", "h36m-text"}, {kText, "h36m-text"}};
  ASSERT_EQ(listed.clips_size(), 3);
  ASSERT_EQ(rest.document["clips"].size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const auto& clip = listed.clips(i);
    EXPECT_EQ(clip.path(), expected[i].first);
    EXPECT_EQ(clip.format(), expected[i].second);
    EXPECT_EQ(clip.size_bytes(), static_cast<int64_t>(fs::file_size(data_root() / clip.path())));
    const json& twin = rest.document["clips"][i];
    EXPECT_EQ(twin["path"], clip.path());
    EXPECT_EQ(twin["format"], clip.format());
    EXPECT_EQ(twin["size_bytes"], clip.size_bytes());
  }
}

TEST_F(ClipsService, AWindowIsEverySecondRowFromStartAndEncodesAsTheRaw50HzRows) {
  const auto rows = read_motion_text((data_root() / kText).string());
  const int64_t start = 33;
  grpc::ClientContext context;
  v1::ReadClipReply window;
  const auto status = read_clip(kText, start, &window, &context);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(window.path(), kText);
  EXPECT_EQ(window.format(), "h36m-text");
  EXPECT_EQ(window.start(), start);
  EXPECT_EQ(window.file_frames(), rows.frame_count());
  EXPECT_EQ(window.file_frame_rate(), 50);
  EXPECT_EQ(window.last_start(), rows.frame_count() - 300);
  const v1::Motion& motion = window.motion();
  EXPECT_EQ(motion.frames(), 150);
  EXPECT_EQ(motion.columns(), 99);
  EXPECT_EQ(motion.frame_rate(), 25);
  EXPECT_EQ(motion.layout(), "h36m-expmap-99");
  std::vector<float> expected;
  for (int64_t k = 0; k < 150; ++k) expected.insert(expected.end(), rows.frame(start + 2 * k), rows.frame(start + 2 * k) + 99);
  EXPECT_EQ(std::vector<float>(motion.values().begin(), motion.values().end()), expected);

  v1::Motion raw;
  raw.set_frames(300);
  raw.set_columns(99);
  raw.set_frame_rate(50);
  raw.set_layout("h36m-expmap-99");
  raw.mutable_values()->Add(rows.frame(start), rows.frame(start + 300));
  const auto code = encode(motion);
  ASSERT_EQ(code.size(), 64u);
  EXPECT_EQ(code, encode(raw));

  // REST answers the same window.
  const test::Reply rest = test::get(port(), "/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt&start=33");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.document["path"], kText);
  EXPECT_EQ(rest.document["file_frames"], rows.frame_count());
  EXPECT_EQ(rest.document["last_start"], rows.frame_count() - 300);
  EXPECT_EQ(rest.document["motion"]["frames"], 150);
  EXPECT_EQ(rest.document["motion"]["frame_rate"], 25);
  EXPECT_EQ(rest.document["motion"]["values"].get<std::vector<float>>(), expected);
}

TEST_F(ClipsService, ABvhOfTheModelsSkeletonIsReadInTheModelsLayoutAndEncodes) {
  const test::Reply rest = test::get(port(), "/v1/clips/window?path=bvh/walking.bvh&start=101");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.document["format"], "bvh");
  EXPECT_EQ(rest.document["file_frames"], 400);
  EXPECT_EQ(rest.document["file_frame_rate"], 50);
  EXPECT_EQ(rest.document["last_start"], 101);
  EXPECT_EQ(rest.document["motion"]["layout"], "h36m-expmap-99");
  grpc::ClientContext context;
  v1::ReadClipReply window;
  ASSERT_TRUE(read_clip(kBvh, 101, &window, &context).ok());
  EXPECT_EQ(std::vector<float>(window.motion().values().begin(), window.motion().values().end()),
            rest.document["motion"]["values"].get<std::vector<float>>());
  EXPECT_EQ(encode(window.motion()).size(), 64u);
}

TEST_F(ClipsService, AWholeReadIsEveryRowOfTheTextFileAt50HzOverBothProtocols) {
  const auto rows = read_motion_text((data_root() / kText).string());
  ASSERT_EQ(rows.frame_count(), 3000);  // S5 walking_1: 60 s at 50 Hz, well past one window
  grpc::ClientContext context;
  v1::ReadClipReply whole;
  const auto status = read_clip(kText, 0, &whole, &context, /*whole=*/true);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(whole.path(), kText);
  EXPECT_EQ(whole.format(), "h36m-text");
  EXPECT_EQ(whole.start(), 0);
  EXPECT_EQ(whole.last_start(), 0);
  EXPECT_EQ(whole.file_frames(), rows.frame_count());
  EXPECT_EQ(whole.file_frame_rate(), 50);
  const v1::Motion& motion = whole.motion();
  EXPECT_EQ(motion.frames(), rows.frame_count());
  EXPECT_EQ(motion.columns(), 99);
  EXPECT_EQ(motion.frame_rate(), 50);
  EXPECT_EQ(motion.layout(), "h36m-expmap-99");
  // The file's values as the library reads them, every row in order.
  EXPECT_EQ(std::vector<float>(motion.values().begin(), motion.values().end()), rows.values);

  const test::Reply rest = test::get(port(), "/v1/clips/motion?path=h36m%2FS5%2Fwalking_1.txt");
  ASSERT_EQ(rest.status, 200) << rest.body.substr(0, 400);
  EXPECT_EQ(rest.document["path"], kText);
  EXPECT_EQ(rest.document["file_frames"], rows.frame_count());
  EXPECT_EQ(rest.document["file_frame_rate"], 50);
  EXPECT_EQ(rest.document["motion"]["frames"], rows.frame_count());
  EXPECT_EQ(rest.document["motion"]["frame_rate"], 50);
  EXPECT_EQ(rest.document["motion"]["layout"], "h36m-expmap-99");
  EXPECT_EQ(rest.document["motion"]["values"].get<std::vector<float>>(), rows.values);

  // A BVH of the model's skeleton: every frame at its own 50 Hz, in the
  // model's layout, as a take of it reads it.
  const test::Reply bvh = test::get(port(), "/v1/clips/motion?path=bvh/walking.bvh");
  ASSERT_EQ(bvh.status, 200) << bvh.body.substr(0, 400);
  EXPECT_EQ(bvh.document["format"], "bvh");
  EXPECT_EQ(bvh.document["file_frames"], 400);
  EXPECT_EQ(bvh.document["motion"]["frames"], 400);
  EXPECT_EQ(bvh.document["motion"]["frame_rate"], 50);
  EXPECT_EQ(bvh.document["motion"]["layout"], "h36m-expmap-99");
  EXPECT_EQ(bvh.document["motion"]["values"].size(), 400u * 99u);
}

// A take with lost markers: values a text marks `nan` come back NaN where
// they are, whole and in a window, over gRPC as floats and over REST as
// proto3's "NaN" (JSON's own writer would have made them null); every other
// value is the file's. Encoding such a window is refused naming the value,
// and a `nan` in the root translation is still a malformed file.
TEST_F(ClipsService, ValuesATextMarksMissingAreReadAsNaNWholeAndInAWindow) {
  auto rows = read_motion_text((data_root() / kText).string());
  rows.values.resize(400 * static_cast<size_t>(rows.columns));
  const auto missing = [&](int64_t f, int c) { return f >= 100 && f < 150 && c >= 6 && c < 21; };
  // The file's own text, its missing fields replaced.
  std::ifstream file(data_root() / kText);
  std::string text, line;
  for (int64_t f = 0; f < rows.frame_count() && std::getline(file, line); ++f) {
    std::stringstream fields(line);
    std::string field;
    for (int c = 0; std::getline(fields, field, ','); ++c) text += (c ? "," : "") + (missing(f, c) ? "nan" : field);
    text += "\n";
  }
  const char* const lost = "h36m/S5/walking_1_lost.txt";
  std::ofstream(data_root() / lost) << text;
  const auto expect_as_file = [&](const std::vector<float>& values, int64_t first_row, int64_t step, const std::string& via) {
    ASSERT_EQ(values.size() % 99, 0u) << via;
    int64_t nans = 0;
    for (size_t i = 0; i < values.size(); ++i) {
      const int64_t f = first_row + step * static_cast<int64_t>(i / 99);
      const int c = static_cast<int>(i % 99);
      if (missing(f, c)) {
        ++nans;
        EXPECT_TRUE(std::isnan(values[i])) << via << ": frame " << f << " column " << c << " is " << values[i];
      } else {
        ASSERT_EQ(values[i], rows.frame(f)[c]) << via << ": frame " << f << " column " << c;
      }
    }
    EXPECT_GT(nans, 0) << via;
  };

  grpc::ClientContext context;
  v1::ReadClipReply whole;
  const auto status = read_clip(lost, 0, &whole, &context, /*whole=*/true);
  ASSERT_TRUE(status.ok()) << status.error_message();
  expect_as_file({whole.motion().values().begin(), whole.motion().values().end()}, 0, 1, "gRPC, whole");

  const test::Reply rest = test::get(port(), "/v1/clips/motion?path=h36m%2FS5%2Fwalking_1_lost.txt");
  ASSERT_EQ(rest.status, 200) << rest.body.substr(0, 400);
  const json& values = rest.document["motion"]["values"];
  ASSERT_EQ(values.size(), 400u * 99u);
  std::vector<float> read;
  for (size_t i = 0; i < values.size(); ++i) {
    if (values[i].is_string()) {
      ASSERT_EQ(values[i], "NaN") << "REST value " << i;
      read.push_back(std::numeric_limits<float>::quiet_NaN());
    } else {
      read.push_back(values[i].get<float>());
    }
  }
  expect_as_file(read, 0, 1, "REST, whole");

  grpc::ClientContext window_context;
  v1::ReadClipReply window;
  const auto window_status = read_clip(lost, 80, &window, &window_context);
  ASSERT_TRUE(window_status.ok()) << window_status.error_message();
  expect_as_file({window.motion().values().begin(), window.motion().values().end()}, 80, 2, "gRPC, a window");
  grpc::ClientContext encode_context;
  v1::EncodeRequest encode;
  *encode.add_motions() = window.motion();
  v1::EncodeReply encoded;
  const auto refused = stub_->Encode(&encode_context, encode, &encoded);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << refused.error_message();
  EXPECT_NE(refused.error_message().find("found NaN"), std::string::npos) << refused.error_message();

  std::ofstream(data_root() / "h36m/S5/root_lost.txt") << "nan" << text.substr(text.find(','));
  grpc::ClientContext root_context;
  v1::ReadClipReply root_reply;
  const auto root_status = read_clip("h36m/S5/root_lost.txt", 0, &root_reply, &root_context, /*whole=*/true);
  EXPECT_EQ(root_status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(error_field(root_context), "path");
  EXPECT_NE(root_status.error_message().find("not a root translation"), std::string::npos) << root_status.error_message();
}

TEST_F(ClipsService, AWholeReadWithAStartIsRefusedNamingStart) {
  grpc::ClientContext context;
  v1::ReadClipReply reply;
  const auto status = read_clip(kText, 5, &reply, &context, /*whole=*/true);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(error_field(context), "start");
  EXPECT_NE(status.error_message().find("expected 0"), std::string::npos) << status.error_message();
  // REST's whole read takes no start at all.
  const test::Reply rest = test::get(port(), "/v1/clips/motion?path=h36m%2FS5%2Fwalking_1.txt&start=5");
  EXPECT_EQ(rest.status, 400) << rest.body;
  EXPECT_EQ(rest.error()["field"], "start") << rest.body;
}

// A BVH of another hierarchy (one joint renamed): its window is read in its
// own layout, but its whole read is refused as a take of it is, in the same
// words, since a take of it could not be filled either.
TEST_F(ClipsService, AWholeReadOfAnotherSkeletonIsRefusedNamingPathAsATakeOfItIs) {
  std::string text = test::read_text((data_root() / kBvh).string());
  const size_t joint = text.find("JOINT ");
  ASSERT_NE(joint, std::string::npos);
  const size_t name = joint + 6, end = text.find_first_of("\r\n", name);
  text.replace(name, end - name, "Renamed");
  std::ofstream((data_root() / "bvh" / "renamed.bvh").string(), std::ios::binary) << text;

  EXPECT_EQ(test::get(port(), "/v1/clips/window?path=bvh/renamed.bvh").document["motion"]["layout"], "expmap-99");
  grpc::ClientContext context;
  v1::ReadClipReply reply;
  const auto status = read_clip("bvh/renamed.bvh", 0, &reply, &context, /*whole=*/true);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(error_field(context), "path");
  const test::Reply take = test::post(port(), "/v1/takes:reconstruct?path=bvh%2Frenamed.bvh", std::string(), {}, "text/plain");
  EXPECT_EQ(take.status, 400) << take.body;
  EXPECT_EQ(take.error()["field"], "path") << take.body;
  // gRPC's message leads with the field it names.
  EXPECT_EQ("path: " + take.error()["message"].get<std::string>(), status.error_message());
  EXPECT_NE(status.error_message().find("not the H3.6M skeleton"), std::string::npos) << status.error_message();
}

TEST_F(ClipsService, RefusalsNameTheFieldOverBothProtocols) {
  const int64_t rows = read_motion_text((data_root() / kText).string()).frame_count();
  // A readable clip in a sibling folder whose name begins with the data
  // root's: a containment check that compares strings, not path elements,
  // would serve it.
  const fs::path sibling = data_root().parent_path() / (data_root().filename().string() + "-sibling");
  fs::create_directories(sibling);
  fs::copy_file(data_root() / kText, sibling / "walking.txt", fs::copy_options::overwrite_existing);
  const std::string sibling_name = sibling.filename().string();
  struct Case {
    std::string path;
    int64_t start;
    grpc::StatusCode code;
    int http_status;
    std::string field, message;
  };
  const std::vector<Case> cases = {
      {kText, rows - 299, grpc::StatusCode::INVALID_ARGUMENT, 400, "start",
       "expected 0 to " + std::to_string(rows - 300)},
      {kText, -1, grpc::StatusCode::INVALID_ARGUMENT, 400, "start", "is negative"},
      {"../outside.txt", 0, grpc::StatusCode::INVALID_ARGUMENT, 400, "path", "outside the data root"},
      {(data_root().parent_path() / "elsewhere.txt").string(), 0, grpc::StatusCode::INVALID_ARGUMENT, 400, "path",
       "outside the data root"},
      {"../" + sibling_name + "/walking.txt", 0, grpc::StatusCode::INVALID_ARGUMENT, 400, "path",
       "outside the data root"},
      {(sibling / "walking.txt").string(), 0, grpc::StatusCode::INVALID_ARGUMENT, 400, "path",
       "outside the data root"},
      {"h36m/S5/walking_9.txt", 0, grpc::StatusCode::NOT_FOUND, 404, "path", "names no file"},
  };
  for (const auto& c : cases) {
    grpc::ClientContext context;
    v1::ReadClipReply reply;
    const auto status = read_clip(c.path, c.start, &reply, &context);
    EXPECT_EQ(status.error_code(), c.code) << c.path << ": " << status.error_message();
    EXPECT_EQ(error_field(context), c.field) << c.path;
    EXPECT_NE(status.error_message().find(c.message), std::string::npos) << status.error_message();

    const test::Reply rest = test::get(port(), "/v1/clips/window?path=" + httplib::detail::encode_query_param(c.path) +
                                            "&start=" + std::to_string(c.start));
    EXPECT_EQ(rest.status, c.http_status) << rest.body;
    EXPECT_EQ(rest.error()["field"], c.field) << rest.body;
    EXPECT_NE(rest.error()["message"].get<std::string>().find(c.message), std::string::npos) << rest.body;
  }
  // What only a query string can get wrong, named by the parameter.
  for (const auto& [query, field] : std::vector<std::pair<std::string, std::string>>{
           {"path=h36m/S5/walking_1.txt&start=ten", "start"},
           {"path=h36m/S5/walking_1.txt&frame=3", "frame"},
           {"path=h36m/S5/walking_1.txt&path=bvh/walking.bvh", "path"}}) {
    const test::Reply rest = test::get(port(), "/v1/clips/window?" + query);
    EXPECT_EQ(rest.status, 400) << query << ": " << rest.body;
    EXPECT_EQ(rest.error()["field"], field) << rest.body;
  }
}

// A NUL ends a name where the C library reads it: ReadClip of
// "walking_1.txt\0.bvh" once answered the text file's window. Refused over
// both protocols, naming the field and the byte, as every control character.
TEST_F(ClipsService, AControlCharacterInAPathIsRefusedNamingItsByteOverBothProtocols) {
  for (const std::string path : {std::string(kText) + std::string(1, '\0') + ".bvh", std::string(kText) + "\n",
                                 std::string("h36m/S5/\x7Fwalking_1.txt")}) {
    const size_t byte = path.find_first_of(std::string("\0\n\x7F", 3));
    const std::string message = "path holds the control character";
    const std::string at = "at byte " + std::to_string(byte);
    grpc::ClientContext context;
    v1::ReadClipReply reply;
    const auto status = read_clip(path, 0, &reply, &context);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(error_field(context), "path");
    EXPECT_NE(status.error_message().find(message), std::string::npos) << status.error_message();
    EXPECT_NE(status.error_message().find(at), std::string::npos) << status.error_message();

    const test::Reply rest =
        test::get(port(), "/v1/clips/window?path=" + httplib::detail::encode_query_param(path) + "&start=0");
    EXPECT_EQ(rest.status, 400) << rest.body;
    ASSERT_TRUE(rest.document.is_object()) << rest.body;
    EXPECT_EQ(rest.error()["field"], "path") << rest.body;
    EXPECT_NE(rest.body.find(message), std::string::npos) << rest.body;
    EXPECT_NE(rest.body.find(at), std::string::npos) << rest.body;
  }
  // The same query written by hand, as a browser or curl sends it.
  const test::Reply rest = test::get(port(), "/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt%00.bvh");
  EXPECT_EQ(rest.status, 400) << rest.body;
  EXPECT_NE(rest.body.find("control character 0x00 at byte 21"), std::string::npos) << rest.body;
}

TEST(ClipsUpload, BothProtocolsWriteNewFilesThatAreListedAndReadAndNeedTheToken) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = make_data_root(scratch.path() / "data");
  test::ServerProcess server({"--data-root", root.string(), "--auth-token", "upload-token"});
  auto stub = v1::MotionManifold::NewStub(grpc::CreateChannel(server.grpc_target(), grpc::InsecureChannelCredentials()));
  const std::string text = test::read_text((root / kText).string());
  const auto upload_grpc = [&](const std::string& path, const std::string& content, const std::string& token,
                               v1::ClipFile* clip, grpc::ClientContext* context) {
    if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
    v1::UploadClipRequest request;
    request.set_path(path);
    request.set_content(content);
    return stub->UploadClip(context, request, clip);
  };
  const auto upload_rest = [&](const std::string& path, const std::string& content, const std::string& token) {
    return test::post(server.rest_port(), "/v1/clips:upload?path=" + path, content,
                      token.empty() ? httplib::Headers{} : test::bearer(token), "application/octet-stream");
  };

  // Written over either protocol, as the file sent, and then one of the clips.
  grpc::ClientContext context;
  v1::ClipFile clip;
  const auto status = upload_grpc("mine/S5/walking_1.txt", text, "upload-token", &clip, &context);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(clip.path(), "mine/S5/walking_1.txt");
  EXPECT_EQ(clip.format(), "h36m-text");
  EXPECT_EQ(clip.size_bytes(), static_cast<int64_t>(text.size()));
  const test::Reply rest = upload_rest("mine/S5/walking_2.txt", text, "upload-token");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.document, (json{{"path", "mine/S5/walking_2.txt"}, {"format", "h36m-text"}, {"size_bytes", text.size()}, {"uploaded", true}}));
  for (const char* name : {"walking_1.txt", "walking_2.txt"}) {
    EXPECT_EQ(test::read_text((root / "mine" / "S5" / name).string()), text) << name;
  }
  std::vector<std::string> listed;
  // The clips of a server with a token are read with it.
  EXPECT_EQ(test::get(server.rest_port(), "/v1/clips").status, 401);
  const test::Reply list = test::get(server.rest_port(), "/v1/clips", test::bearer("upload-token"));
  for (const auto& c : list.document["clips"]) listed.push_back(c["path"]);
  EXPECT_EQ(listed, (std::vector<std::string>{kBvh, "h36m/S1/eating_1.txt", kText, "mine/S5/walking_1.txt",
                                              "mine/S5/walking_2.txt"}))
      << list.body;
  const test::Reply window = test::get(server.rest_port(), "/v1/clips/window?path=mine/S5/walking_2.txt&start=4",
                                       test::bearer("upload-token"));
  const test::Reply original = test::get(server.rest_port(), std::string("/v1/clips/window?path=") + kText + "&start=4",
                                         test::bearer("upload-token"));
  ASSERT_EQ(window.status, 200) << window.body;
  EXPECT_EQ(window.document["motion"], original.document["motion"]);

  // Without the token, or of a file that is there: refused, nothing written.
  {
    grpc::ClientContext refused;
    EXPECT_EQ(upload_grpc("mine/other.txt", text, "", &clip, &refused).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
  EXPECT_EQ(upload_rest("mine/other.txt", text, "wrong").status, 401);
  EXPECT_FALSE(fs::exists(root / "mine" / "other.txt"));
  {
    grpc::ClientContext refused;
    const auto again = upload_grpc("mine/S5/walking_1.txt", "0", "upload-token", &clip, &refused);
    EXPECT_EQ(again.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << again.error_message();
    EXPECT_EQ(error_field(refused), "path");
  }
  EXPECT_EQ(test::read_text((root / "mine" / "S5" / "walking_1.txt").string()), text);
  // Refusals name the field alike.
  for (const auto& [path, content, field] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"../escape.txt", text, "path"}, {"mine/x.obj", text, "path"}, {"mine/bad.bvh", "HIERARCHY\n", "content"},
           {"mine/x.fbx", text, "content"}}) {
    grpc::ClientContext refused;
    EXPECT_EQ(upload_grpc(path, content, "upload-token", &clip, &refused).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT) << path;
    EXPECT_EQ(error_field(refused), field) << path;
    const test::Reply bad = upload_rest(path, content, "upload-token");
    EXPECT_EQ(bad.status, 400) << path << ": " << bad.body;
    EXPECT_EQ(bad.error()["field"], field) << bad.body;
  }
  {
    // A NUL refused by the same check as ReadClip's, naming its byte.
    grpc::ClientContext refused;
    const auto nul = upload_grpc(std::string("mine/nul.txt\0.bvh", 17), text, "upload-token", &clip, &refused);
    EXPECT_EQ(nul.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << nul.error_message();
    EXPECT_EQ(error_field(refused), "path");
    EXPECT_NE(nul.error_message().find("control character 0x00 at byte 12"), std::string::npos) << nul.error_message();
    const test::Reply bad = upload_rest("mine/nul.txt%00.bvh", text, "upload-token");
    EXPECT_EQ(bad.status, 400) << bad.body;
    EXPECT_NE(bad.body.find("control character 0x00 at byte 12"), std::string::npos) << bad.body;
  }
  const test::Reply unknown = upload_rest("mine/y.txt&start=3", text, "upload-token");
  EXPECT_EQ(unknown.status, 400) << unknown.body;
  EXPECT_EQ(unknown.error()["field"], "start") << unknown.body;
}

// Reads S5 walking_1 whole from `server` over gRPC, expecting a refusal
// naming path and saying each of `said`, and over REST `rest_path` (a file
// of the data root, URL-encoded) refused naming path; a window of walking_1
// is no whole read and is still answered. Returns REST's refusal.
test::Reply expect_whole_reads_refused(const test::ServerProcess& server, const std::vector<std::string>& said,
                                       const std::string& rest_path) {
  auto stub = v1::MotionManifold::NewStub(grpc::CreateChannel(server.grpc_target(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  v1::ReadClipRequest request;
  request.set_path(kText);
  request.set_whole(true);
  v1::ReadClipReply reply;
  const auto status = stub->ReadClip(&context, request, &reply);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(error_field(context), "path");
  for (const std::string& phrase : said) {
    EXPECT_NE(status.error_message().find(phrase), std::string::npos) << phrase << ": " << status.error_message();
  }
  const test::Reply rest = test::get(server.rest_port(), "/v1/clips/motion?path=" + rest_path);
  EXPECT_EQ(rest.status, 400) << rest.body;
  EXPECT_EQ(rest.error()["field"], "path") << rest.body;
  EXPECT_EQ(test::get(server.rest_port(), "/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt").status, 200);
  return rest;
}

// The whole read is bounded as a take is: S5 walking_1 (60 s) on a server
// whose longest take is 6 s.
TEST(ClipsWholeRead, AFileLongerThanTheLongestTakeIsRefusedNamingPathItsLengthAndTheLimit) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  test::ServerProcess server({"--data-root", make_data_root(scratch.path() / "data").string(), "--max-take-seconds", "6"});
  const test::Reply rest = expect_whole_reads_refused(
      server, {"h36m/S5/walking_1.txt", "3000 frames at 50 Hz", "59.98 s", "--max-take-seconds 6"}, "bvh%2Fwalking.bvh");
  EXPECT_NE(rest.error()["message"].get<std::string>().find("400 frames at 50 Hz"), std::string::npos) << rest.body;
}

// A whole read is one reply: S5 walking_1 read whole is 3000 x 99 floats
// (1.13 MiB), refused before it is made on a server whose messages are 1 MB.
TEST(ClipsWholeRead, AFileLargerThanOneMessageIsRefusedNamingPathItsSizeAndTheLimit) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  test::ServerProcess server(
      {"--data-root", make_data_root(scratch.path() / "data").string(), "--max-message-bytes", "1000000"});
  expect_whole_reads_refused(
      server, {"h36m/S5/walking_1.txt", "3000 frames of 99 values", "1.1 MiB", "--max-message-bytes 1000000"},
      "h36m%2FS5%2Fwalking_1.txt");
}

TEST(ClipsWithoutDataRoot, BothProtocolsAnswerFailedPreconditionNamingTheFlag) {
  MM_REQUIRE_H36M();
  test::ServerProcess server;
  const test::Reply rest = test::get(server.rest_port(), "/v1/clips");
  EXPECT_EQ(rest.status, 409) << rest.body;
  EXPECT_EQ(rest.error()["code"], "FAILED_PRECONDITION");
  EXPECT_NE(rest.error()["message"].get<std::string>().find("--data-root"), std::string::npos);
  auto stub = v1::MotionManifold::NewStub(grpc::CreateChannel(server.grpc_target(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  v1::ReadClipRequest request;
  request.set_path(kText);
  v1::ReadClipReply reply;
  const auto status = stub->ReadClip(&context, request, &reply);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_NE(status.error_message().find("--data-root"), std::string::npos) << status.error_message();
}

}  // namespace
}  // namespace mm
