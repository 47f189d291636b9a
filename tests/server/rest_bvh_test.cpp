// REST with BVH bodies: the real server on loopback, /v1/encode and
// /v1/denoise taking Content-Type application/x-bvh, the motion replies
// given as BVH for Accept: application/x-bvh (one motion; several are 406).
// Needs only the shipped model: the motions are synthetic.
#include <httplib.h>

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/motion_frames.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

using json = nlohmann::json;

// 150 frames at 25 Hz of small random rotations, the model's clip.
MotionFrames clip() {
  std::mt19937 random(4);
  std::normal_distribution<float> angle(0.0f, 0.2f);
  MotionFrames motion;
  motion.values.assign(150 * kH36mColumns, 0.0f);
  for (int f = 0; f < 150; ++f)
    for (int c = 3; c < kH36mColumns; ++c) motion.frame(f)[c] = 0.1f + angle(random) * 0.1f;
  return motion;
}

json motion_json(const MotionFrames& motion) {
  return json{{"frames", motion.frame_count()}, {"columns", motion.columns}, {"frame_rate", 25},
              {"layout", "h36m-expmap-99"}, {"values", motion.values}};
}

class RestBvh : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new test::ServerProcess(); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static httplib::Client client() { return test::rest_client(server_->rest_port()); }
  static test::ServerProcess* server_;
};
test::ServerProcess* RestBvh::server_ = nullptr;

TEST_F(RestBvh, EncodeOfABvhBodyIsTheCodeOfTheSameMotionAsJson) {
  auto c = client();
  const MotionFrames motion = clip();
  const auto from_json = c.Post("/v1/encode", json{{"motions", {motion_json(motion)}}}.dump(), "application/json");
  const auto from_bvh = c.Post("/v1/encode", h36m_motion_to_bvh_text(motion, 25.0), "application/x-bvh");
  ASSERT_TRUE(from_json && from_bvh);
  ASSERT_EQ(from_json->status, 200) << from_json->body;
  ASSERT_EQ(from_bvh->status, 200) << from_bvh->body;
  const auto a = json::parse(from_json->body)["codes"][0].get<std::vector<double>>();
  const auto b = json::parse(from_bvh->body)["codes"][0].get<std::vector<double>>();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-3) << i;
}

TEST_F(RestBvh, DecodeAnswersBvhWhenAcceptedAndTheSameMotionAsJson) {
  auto c = client();
  const json body = {{"codes", {std::vector<float>(64, 0.1f)}}};
  const auto as_json = c.Post("/v1/decode", body.dump(), "application/json");
  const auto as_bvh = c.Post("/v1/decode", httplib::Headers{{"Accept", "application/x-bvh"}}, body.dump(),
                             "application/json");
  ASSERT_TRUE(as_json && as_bvh);
  ASSERT_EQ(as_bvh->status, 200) << as_bvh->body;
  EXPECT_EQ(as_bvh->get_header_value("Content-Type"), "application/x-bvh");
  const BvhFile file = parse_bvh_text(as_bvh->body, "reply.bvh");
  EXPECT_EQ(file.frame_count(), 150);
  EXPECT_DOUBLE_EQ(file.frame_time_s, 0.04);
  // The BVH's poses are the JSON motion's: exported again from the JSON
  // values, every joint is within 0.1 mm.
  const json motion = json::parse(as_json->body)["motions"][0];
  MotionFrames frames;
  frames.values = motion["values"].get<std::vector<float>>();
  const BvhFile expected = h36m_motion_to_bvh(frames, 25.0);
  for (int64_t f : {0, 75, 149}) {
    const auto got = bvh_world_positions(file, f), want = bvh_world_positions(expected, f);
    for (size_t j = 0; j < got.size(); ++j)
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(got[j][k], want[j][k], 0.1) << "frame " << f << " joint " << j;
  }
}

TEST_F(RestBvh, SeveralMotionsAsBvhAre406NamingTheCount) {
  auto c = client();
  const auto reply = c.Post("/v1/sample", httplib::Headers{{"Accept", "application/x-bvh"}},
                            json{{"count", 3}, {"seed", 1}}.dump(), "application/json");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 406);
  EXPECT_NE(reply->body.find("this reply has 3"), std::string::npos) << reply->body;
  const auto one = c.Post("/v1/sample", httplib::Headers{{"Accept", "application/x-bvh"}},
                          json{{"count", 1}, {"seed", 1}}.dump(), "application/json");
  ASSERT_TRUE(one);
  EXPECT_EQ(one->status, 200) << one->body;
  EXPECT_EQ(one->body.rfind("HIERARCHY", 0), 0u);
}

TEST_F(RestBvh, DenoiseTakesAndGivesBvh) {
  auto c = client();
  const auto reply = c.Post("/v1/denoise", httplib::Headers{{"Accept", "application/x-bvh"}},
                            h36m_motion_to_bvh_text(clip(), 25.0), "application/x-bvh");
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->status, 200) << reply->body;
  EXPECT_EQ(parse_bvh_text(reply->body, "denoised.bvh").frame_count(), 150);
}

TEST_F(RestBvh, AnotherSkeletonOrAMalformedBvhIs400) {
  auto c = client();
  const std::string other =
      "HIERARCHY\nROOT hip\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Yrotation Xrotation\n End Site\n {\n  OFFSET 0 1 0\n"
      " }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0\n";
  auto reply = c.Post("/v1/encode", other, "application/x-bvh");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 400);
  EXPECT_NE(reply->body.find("not the H3.6M skeleton"), std::string::npos) << reply->body;
  reply = c.Post("/v1/denoise", "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 x\n", "application/x-bvh");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 400);
  EXPECT_NE(reply->body.find("request body:4:"), std::string::npos) << reply->body;
  // A BVH of the right skeleton but too short for the model: the core's 400.
  MotionFrames short_clip = clip();
  short_clip.values.resize(10 * kH36mColumns);
  reply = c.Post("/v1/encode", h36m_motion_to_bvh_text(short_clip, 25.0), "application/x-bvh");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 400) << reply->body;
}

}  // namespace
}  // namespace mm
