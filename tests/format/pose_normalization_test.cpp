#include "format/pose_normalization.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "format/input_error.h"

namespace mm {
namespace {

using ::testing::HasSubstr;

// 5 columns: 0..2 "root translation", 3 varies, 4 constant.
MotionFrames synthetic() {
  MotionFrames motion;
  motion.columns = 5;
  motion.values = {1, 2, 3, 10, 7,  //
                   4, 5, 6, 20, 7,  //
                   7, 8, 9, 30, 7};
  return motion;
}

TEST(PoseNormalization, FitKeepsVaryingNonRootColumnsWithPopulationStd) {
  const MotionFrames motion = synthetic();
  const PoseNormalization norm = PoseNormalization::fit({&motion});
  EXPECT_EQ(norm.input_columns(), 5);
  EXPECT_EQ(norm.kept_columns, std::vector<int>{3});
  EXPECT_FLOAT_EQ(norm.mean[3], 20.0f);
  EXPECT_FLOAT_EQ(norm.stddev[3], std::sqrt(200.0f / 3.0f));
  EXPECT_FLOAT_EQ(norm.stddev[4], 0.0f);
}

TEST(PoseNormalization, FitCanKeepRootTranslation) {
  const MotionFrames motion = synthetic();
  const PoseNormalization norm = PoseNormalization::fit({&motion}, 1e-4, false);
  EXPECT_EQ(norm.kept_columns, (std::vector<int>{0, 1, 2, 3}));
}

TEST(PoseNormalization, FitOnZeroFramesIsInputError) {
  MotionFrames empty;
  EXPECT_THROW(PoseNormalization::fit({}), InputError);
  EXPECT_THROW(PoseNormalization::fit({&empty}), InputError);
}

TEST(PoseNormalization, NormalizeDenormalizeRoundTrip) {
  const MotionFrames motion = synthetic();
  const PoseNormalization norm = PoseNormalization::fit({&motion});
  const MotionFrames normalized = norm.normalize(motion);
  EXPECT_EQ(normalized.columns, 1);
  EXPECT_NEAR(normalized.values[0], -10.0 / std::sqrt(200.0 / 3.0), 1e-6);
  const MotionFrames back = norm.denormalize(normalized);
  ASSERT_EQ(back.columns, 5);
  for (int64_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.frame(i)[0], 0.0f) << "dropped root translation comes back as 0";
    EXPECT_EQ(back.frame(i)[2], 0.0f);
    EXPECT_NEAR(back.frame(i)[3], motion.frame(i)[3], 1e-5);
    EXPECT_EQ(back.frame(i)[4], 7.0f) << "constant column comes back as its mean";
  }
}

TEST(PoseNormalization, RejectsMotionWithWrongColumnCount) {
  const MotionFrames motion = synthetic();
  const PoseNormalization norm = PoseNormalization::fit({&motion});
  MotionFrames wrong;
  wrong.columns = 4;
  wrong.values.assign(8, 0.0f);
  EXPECT_THROW(norm.normalize(wrong), InputError);
  EXPECT_THROW(norm.denormalize(wrong), InputError);
}

TEST(PoseNormalization, JsonRoundTripIsExact) {
  const MotionFrames motion = synthetic();
  PoseNormalization norm = PoseNormalization::fit({&motion});
  norm.mean[4] = 0.1f;  // not exactly representable in decimal
  norm.position_scale_mm = 123.25;
  const PoseNormalization copy = PoseNormalization::from_json_text(norm.to_json_text(), "norm.json");
  EXPECT_EQ(copy.mean, norm.mean);
  EXPECT_EQ(copy.stddev, norm.stddev);
  EXPECT_EQ(copy.kept_columns, norm.kept_columns);
  EXPECT_EQ(copy.position_scale_mm, 123.25);
  EXPECT_EQ(copy.drop_root_translation, true);
}

TEST(PoseNormalization, FromJsonRejectsInconsistentDocuments) {
  const MotionFrames motion = synthetic();
  const nlohmann::json good = nlohmann::json::parse(PoseNormalization::fit({&motion}).to_json_text());
  auto rejects = [&](const char* field, nlohmann::json value, const char* expected_text) {
    nlohmann::json document = good;
    document[field] = std::move(value);
    try {
      PoseNormalization::from_json_text(document.dump(), "norm.json");
      ADD_FAILURE() << "accepted " << field << " = " << document[field].dump();
    } catch (const InputError& error) {
      EXPECT_THAT(error.what(), HasSubstr("norm.json"));
      EXPECT_THAT(error.what(), HasSubstr(expected_text));
    }
  };
  rejects("stddev", {1, 1, 1, 1}, "\"stddev\" has 4 values");
  rejects("kept_columns", {4}, "stddev");        // stddev of column 4 is 0
  rejects("kept_columns", {7}, "[0, 5)");
  rejects("kept_columns", {1}, "root translation");
  rejects("kept_columns", {3, 3}, "increasing");
  rejects("mean", {1, 2, "x", 4, 5}, "element 2");
  rejects("position_scale_mm", -1.0, "position_scale_mm");
  rejects("version", 99, "version");
}

}  // namespace
}  // namespace mm
