// What the REST and the gRPC frontends' fake-core tests exchange with the
// core alike: the reply the core answers, and the fields a Decode and a
// Sample must reach it with (each test sends the same values in its own
// protocol), so that the two frontends are held to one expectation.
#pragma once

#include <gtest/gtest.h>

#include <optional>

#include "server/api/api_types.h"

namespace mm::test {

// A reply of one small motion (2 frames of 3 columns) and its code, with
// every field set, for the frontends to translate.
inline service::MotionsReply one_motion_reply() {
  service::MotionsReply reply;
  reply.answered_by = {"fake-model", "0123456789abcdef"};
  service::Motion motion;
  motion.frames = 2;
  motion.columns = 3;
  motion.frame_rate = 25;
  motion.layout = "test-layout-3";
  motion.values = {1, 2, 3, 4, 5, 6.5f};
  motion.root = "generated";
  motion.contacts = {1, 2};
  reply.motions.push_back(motion);
  reply.codes = {{0.25f, -0.5f}};
  return reply;
}

// The Decode both tests send: model "m1", codes (0.5, -1.25) and (2, 3),
// decoder "velocity", plant_feet.
inline void expect_the_decode_sent(const std::optional<service::DecodeRequest>& sent) {
  ASSERT_TRUE(sent.has_value());
  EXPECT_EQ(sent->model, "m1");
  ASSERT_EQ(sent->codes.size(), 2u);
  EXPECT_EQ(sent->codes[0], (service::Code{0.5f, -1.25f}));
  EXPECT_EQ(sent->codes[1], (service::Code{2, 3}));
  EXPECT_EQ(sent->decoder, "velocity");
  EXPECT_TRUE(sent->plant_feet);
}

// The Sample both tests send: model "m2", count 3, the largest seed,
// decoder "rotation", no plant_feet.
inline void expect_the_sample_sent(const std::optional<service::SampleRequest>& sent) {
  ASSERT_TRUE(sent.has_value());
  EXPECT_EQ(sent->model, "m2");
  EXPECT_EQ(sent->count, 3);
  EXPECT_EQ(sent->seed, 18446744073709551615ull);
  EXPECT_EQ(sent->decoder, "rotation");
  EXPECT_FALSE(sent->plant_feet);
}

}  // namespace mm::test
