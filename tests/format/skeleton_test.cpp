#include "format/skeleton.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "format/input_error.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string skeleton_json_path() { return test::shared_dir() + "/data/h36m-skeleton.json"; }

void expect_same(const Skeleton& a, const Skeleton& b) {
  EXPECT_EQ(a.name, b.name);
  ASSERT_EQ(a.joint_count(), b.joint_count());
  for (int j = 0; j < a.joint_count(); ++j) {
    SCOPED_TRACE("joint " + std::to_string(j));
    EXPECT_EQ(a.joints[j].name, b.joints[j].name);
    EXPECT_EQ(a.joints[j].parent, b.joints[j].parent);
    EXPECT_EQ(a.joints[j].offset_mm, b.joints[j].offset_mm);
  }
}

std::string error_for(const nlohmann::json& document) {
  try {
    Skeleton::from_json_text(document.dump(), "test.json");
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "accepted " << document.dump();
  return "";
}

nlohmann::json two_joints() {
  return nlohmann::json::parse(R"({"name": "tiny", "joints": [
      {"index": 0, "name": "Root", "parent": -1, "offset": [0, 0, 0]},
      {"index": 1, "name": "Tip", "parent": 0, "offset": [0, 100.5, 0]}]})");
}

TEST(Skeleton, BuiltInH36mEqualsSharedJsonFile) {
  if (!std::filesystem::exists(skeleton_json_path())) GTEST_SKIP() << skeleton_json_path() << " missing";
  expect_same(Skeleton::h36m(), read_skeleton_file(skeleton_json_path()));
}

TEST(Skeleton, BuiltInH36mHas32JointsWithParentsFirst) {
  const Skeleton skeleton = Skeleton::h36m();
  EXPECT_EQ(skeleton.name, "h36m-32");
  ASSERT_EQ(skeleton.joint_count(), 32);
  EXPECT_EQ(skeleton.joints[0].parent, -1);
  for (int j = 1; j < 32; ++j) EXPECT_LT(skeleton.joints[j].parent, j);
  EXPECT_DOUBLE_EQ(skeleton.joints[2].offset_mm[1], -442.894612);
}

TEST(Skeleton, JsonRoundTripIsExact) {
  const Skeleton original = Skeleton::h36m();
  expect_same(Skeleton::from_json_text(original.to_json_text(), "roundtrip"), original);
}

TEST(Skeleton, AcceptsMinimalValidSkeleton) {
  const Skeleton skeleton = Skeleton::from_json_text(two_joints().dump(), "tiny.json");
  EXPECT_EQ(skeleton.joint_count(), 2);
  EXPECT_EQ(skeleton.joints[1].offset_mm[1], 100.5);
}

TEST(Skeleton, RejectsParentThatDoesNotPrecedeTheJoint) {
  nlohmann::json document = two_joints();
  document["joints"][1]["parent"] = 1;
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("test.json"), HasSubstr("joint 1"), HasSubstr("\"Tip\""),
                                         HasSubstr("\"parent\""), HasSubstr("is 1")));
}

TEST(Skeleton, RejectsSecondRoot) {
  nlohmann::json document = two_joints();
  document["joints"][1]["parent"] = -1;
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("joint 1"), HasSubstr("\"parent\"")));
}

TEST(Skeleton, RejectsRootWithParent) {
  nlohmann::json document = two_joints();
  document["joints"][0]["parent"] = 0;
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("joint 0"), HasSubstr("expected -1")));
}

TEST(Skeleton, RejectsIndexThatDiffersFromPosition) {
  nlohmann::json document = two_joints();
  document["joints"][1]["index"] = 5;
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("joint 1"), HasSubstr("\"index\" is 5")));
}

TEST(Skeleton, RejectsOffsetWithoutThreeNumbers) {
  nlohmann::json document = two_joints();
  document["joints"][1]["offset"] = {1, 2};
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("\"Tip\""), HasSubstr("\"offset\""), HasSubstr("[1,2]")));
  document["joints"][1]["offset"] = {1, "x", 3};
  EXPECT_THAT(error_for(document), AllOf(HasSubstr("\"offset\" element 1"), HasSubstr("\"x\"")));
}

TEST(Skeleton, RejectsDuplicateNamesAndEmptyJointList) {
  nlohmann::json document = two_joints();
  document["joints"][1]["name"] = "Root";
  EXPECT_THAT(error_for(document), HasSubstr("repeats"));
  document["joints"] = nlohmann::json::array();
  EXPECT_THAT(error_for(document), HasSubstr("\"joints\""));
}

TEST(Skeleton, RejectsTextThatIsNotJson) {
  EXPECT_THROW(Skeleton::from_json_text("{not json", "broken.json"), InputError);
}

}  // namespace
}  // namespace mm
