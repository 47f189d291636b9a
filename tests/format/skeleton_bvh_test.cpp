// A user's own skeleton, on the CMU dances (43 joints and 14 end sites, cm,
// 120 Hz): BVH -> the skeleton's exp-map layout -> BVH keeps the world
// positions a BVH reader computes, in the rig's own channel layout or any
// other rotation order; a BVH of another hierarchy is refused naming what
// differs (a folder of them as training data: rig_folder_dataset_test.cpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/input_error.h"
#include "format/skeleton_bvh.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

std::string cmu(const std::string& relative) { return (test::cmu_dance_dir() / relative).string(); }

// The source frame that import takes for 25 Hz frame k (nearest in time).
int64_t source_frame(const BvhFile& file, int64_t k) {
  return std::min<int64_t>(static_cast<int64_t>(std::floor(k / 25.0 / file.frame_time_s + 0.5)),
                           file.frame_count() - 1);
}

// Every joint's world position relative to the root's, and the root's own
// position, where the file put it: what a round trip must keep.
void expect_same_poses(const BvhFile& original, const BvhFile& exported, double tolerance) {
  ASSERT_EQ(original.joints.size(), exported.joints.size());
  for (int64_t k = 0; k < exported.frame_count(); k += 7) {
    const std::vector<Vec3> want = bvh_world_positions(original, source_frame(original, k));
    const std::vector<Vec3> got = bvh_world_positions(exported, k);
    for (size_t j = 0; j < want.size(); ++j) {
      for (int a = 0; a < 3; ++a) {
        ASSERT_NEAR(got[j][a] - got[0][a], want[j][a] - want[0][a], tolerance) << "frame " << k << " joint " << j;
      }
    }
    for (int a = 0; a < 3; ++a) ASSERT_NEAR(got[0][a], want[0][a], tolerance) << "root, frame " << k;
  }
}

TEST(SkeletonBvh, CmuDanceRoundTripKeepsWorldPositionsInItsOwnLayout) {
  for (const char* name : {"indian/04.bvh", "martial/07.bvh"}) {
    SCOPED_TRACE(name);
    const BvhFile original = read_bvh_file(cmu(name));
    const Skeleton skeleton = bvh_skeleton(original, "cmu-dance", 10.0);
    const MotionFrames motion = skeleton_motion_from_bvh(skeleton, original, name);
    EXPECT_EQ(motion.columns, 3 + 3 * 57);
    EXPECT_EQ(motion.frame_count(),
              static_cast<int64_t>(std::floor((original.frame_count() - 1) * original.frame_time_s * 25 + 1e-9)) + 1);
    const BvhFile exported = skeleton_motion_to_bvh(skeleton, *skeleton.bvh, motion, 25);
    // The same rig: names, parents, offsets, End Sites and channels.
    for (size_t j = 0; j < original.joints.size(); ++j) {
      EXPECT_EQ(exported.joints[j].name, original.joints[j].name);
      EXPECT_EQ(exported.joints[j].parent, original.joints[j].parent);
      EXPECT_EQ(exported.joints[j].end_site, original.joints[j].end_site);
      EXPECT_EQ(exported.joints[j].channels, original.joints[j].channels);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(exported.joints[j].offset[a], original.joints[j].offset[a], 1e-9);
    }
    // Through the text, as a file on disk: cm to rounding of 6 decimals
    // and of the float exponential maps.
    expect_same_poses(original, parse_bvh_text(write_bvh_text(exported), "exported.bvh"), 2e-3);
  }
}

TEST(SkeletonBvh, AtTheFilesRateEveryFrameIsKeptAndExportsBackAtThatRate) {
  const char* name = "indian/04.bvh";
  const BvhFile original = read_bvh_file(cmu(name));
  const Skeleton skeleton = bvh_skeleton(original, "cmu-dance", 10.0);
  const MotionFrames own = skeleton_motion_from_bvh_at_file_rate(skeleton, original, name);
  ASSERT_EQ(own.frame_count(), original.frame_count());
  // The 25 Hz import is its frames nearest to k / 25 s: their rotations.
  const MotionFrames at_25 = skeleton_motion_from_bvh(skeleton, original, name);
  for (int64_t k = 0; k < at_25.frame_count(); k += 13) {
    const int64_t frame = static_cast<int64_t>(std::floor(k / 25.0 / original.frame_time_s + 0.5));
    for (int c = 3; c < own.columns; ++c) ASSERT_EQ(own.frame(frame)[c], at_25.frame(k)[c]) << k << " " << c;
  }
  // Exported at the file's rate, frame for frame the same poses.
  const BvhFile exported = skeleton_motion_to_bvh(skeleton, *skeleton.bvh, own, 1.0 / original.frame_time_s);
  ASSERT_EQ(exported.frame_count(), original.frame_count());
  EXPECT_DOUBLE_EQ(exported.frame_time_s, original.frame_time_s);
  // Written at 120 Hz with a frame time of 9 significant digits, read back
  // at 120 Hz (the CMU files' own 0.008333 s is 120.0048 Hz).
  const BvhFile read_back =
      parse_bvh_text(write_bvh_text(skeleton_motion_to_bvh(skeleton, *skeleton.bvh, own, 120.0)), "exported.bvh");
  EXPECT_NE(1.0 / read_back.frame_time_s, 120.0);
  EXPECT_EQ(bvh_frame_rate(read_back), 120.0);
  // The CMU files' own frame time, 8 significant digits (120.000048 Hz),
  // says 120 Hz too; one that is not a rounding of a round rate keeps its own.
  BvhFile cmu = read_back;
  cmu.frame_time_s = 0.00833333;
  EXPECT_EQ(bvh_frame_rate(cmu), 120.0);
  cmu.frame_time_s = 0.0083;
  EXPECT_NEAR(bvh_frame_rate(cmu), 120.481928, 1e-9);
  for (int64_t f = 0; f < original.frame_count(); f += 97) {
    const std::vector<Vec3> want = bvh_world_positions(original, f);
    const std::vector<Vec3> got = bvh_world_positions(exported, f);
    for (size_t j = 1; j < want.size(); ++j) {
      for (int a = 0; a < 3; ++a) ASSERT_NEAR(got[j][a] - got[0][a], want[j][a] - want[0][a], 1e-3) << f << " " << j;
    }
  }
}

TEST(SkeletonBvh, AnyRotationOrderGivesTheSamePosesAndReadsBack) {
  const BvhFile original = read_bvh_file(cmu("martial/05.bvh"));
  const Skeleton skeleton = bvh_skeleton(original, "cmu-dance", 10.0);
  const MotionFrames motion = skeleton_motion_from_bvh(skeleton, original, "martial/05.bvh");
  std::mt19937 random(3);
  for (const char* order : {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "mixed"}) {
    SCOPED_TRACE(order);
    BvhLayout layout = *skeleton.bvh;
    for (auto& channels : layout.channels) {
      if (channels.empty()) continue;
      std::string axes = order;
      if (axes == "mixed") {
        axes = "XYZ";
        std::shuffle(axes.begin(), axes.end(), random);
      }
      std::vector<std::string> reordered;
      for (const auto& channel : channels) {
        if (channel.find("position") != std::string::npos) reordered.push_back(channel);
      }
      for (char axis : axes) reordered.push_back(std::string(1, axis) + "rotation");
      channels = reordered;
    }
    const BvhFile exported = parse_bvh_text(write_bvh_text(skeleton_motion_to_bvh(skeleton, layout, motion, 25)), "x");
    expect_same_poses(original, exported, 2e-3);
    // And it reads back as the same motion of the skeleton.
    const MotionFrames back = skeleton_motion_from_bvh(skeleton, exported, "exported.bvh");
    const BvhFile again = skeleton_motion_to_bvh(skeleton, *skeleton.bvh, back, 25);
    expect_same_poses(original, again, 4e-3);
  }
}

TEST(SkeletonBvh, AnotherHierarchyIsRefusedNamingWhatDiffers) {
  const BvhFile cmu_file = read_bvh_file(cmu("indian/06.bvh"));
  const Skeleton skeleton = bvh_skeleton(cmu_file, "cmu-dance", 10.0);

  // H3.6M's hierarchy: the counts of both.
  MotionFrames h36m;
  h36m.values.assign(kH36mColumns, 0.0f);
  EXPECT_THAT(error_of([&] { skeleton_motion_from_bvh(skeleton, h36m_motion_to_bvh(h36m, 25), "h36m.bvh"); }),
              AllOf(HasSubstr("h36m.bvh: not the skeleton \"cmu-dance\": it has 25 joints and 7 end sites, the "
                              "skeleton \"cmu-dance\" 43 joints and 14 end sites"),
                    HasSubstr("missing joints: hip"), HasSubstr("unexpected joints: ")));

  // A renamed joint: missing and unexpected.
  BvhFile renamed = cmu_file;
  auto joint = [&](BvhFile& file, const std::string& name) -> BvhJoint& {
    return *std::find_if(file.joints.begin(), file.joints.end(), [&](const BvhJoint& j) { return j.name == name; });
  };
  joint(renamed, "lShin").name = "lKnee";
  EXPECT_THAT(error_of([&] { skeleton_motion_from_bvh(skeleton, renamed, "renamed.bvh"); }),
              AllOf(HasSubstr("missing joints: lShin"), HasSubstr("unexpected joints: lKnee")));

  // A joint under another parent.
  BvhFile moved = cmu_file;
  const int chest = static_cast<int>(&joint(moved, "chest") - moved.joints.data());
  joint(moved, "neck").parent = chest - 1;  // abdomen
  EXPECT_THAT(error_of([&] { skeleton_motion_from_bvh(skeleton, moved, "moved.bvh"); }),
              HasSubstr("a different parent: neck's parent is abdomen, expected chest"));

  // The same hierarchy with other offsets and channel orders is accepted.
  BvhFile other_person = cmu_file;
  for (auto& j : other_person.joints) j.offset[1] *= 1.1;
  EXPECT_NO_THROW(skeleton_motion_from_bvh(skeleton, other_person, "taller.bvh"));
}

TEST(SkeletonBvh, SkeletonKeepsItsBvhLayoutThroughJson) {
  const BvhFile file = read_bvh_file(cmu("indian/04.bvh"));
  const Skeleton skeleton = bvh_skeleton(file, "cmu-dance", 10.0);
  const Skeleton again = Skeleton::from_json_text(skeleton.to_json_text(), "skeleton.json");
  ASSERT_TRUE(again.bvh.has_value());
  EXPECT_EQ(again.bvh->millimetres_per_unit, 10.0);
  EXPECT_EQ(again.bvh->channels, skeleton.bvh->channels);
  EXPECT_EQ(again.bvh->end_site, skeleton.bvh->end_site);
  EXPECT_EQ(again.bvh->channels[0].size(), 6u);
  EXPECT_EQ(again.bvh->channels[1], (std::vector<std::string>{"Zrotation", "Xrotation", "Yrotation"}));

  // A layout that cannot be written is refused naming the joint.
  std::string text = skeleton.to_json_text();
  const size_t at = text.find("\"Zrotation\"");
  text.replace(at, 11, "\"Wrotation\"");
  EXPECT_THAT(error_of([&] { Skeleton::from_json_text(text, "bad.json"); }),
              AllOf(HasSubstr("bad.json: field \"bvh\" joint 0 (\"hip\")"), HasSubstr("\"Wrotation\"")));
}

}  // namespace
}  // namespace mm
