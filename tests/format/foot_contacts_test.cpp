// Feet on the floor (format/foot_contacts.h): the feet of H3.6M's skeleton
// and of a BVH rig, the floor under a motion, planted feet and skating, the
// root height from the poses and the correction that plants the feet.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "format/foot_contacts.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "tests/common/test_environment.h"
#include "tests/format/h36m_pose.h"

namespace mm {
namespace {

// `frames` copies of the rest pose (all rotations zero) whose root moves
// `step_mm` along x each frame.
MotionFrames sliding_rest_pose(int64_t frames, float step_mm) {
  MotionFrames motion;
  motion.columns = kH36mColumns;
  motion.values.assign(static_cast<size_t>(frames * kH36mColumns), 0.0f);
  for (int64_t f = 1; f < frames; ++f) motion.frame(f)[0] = step_mm;
  return motion;
}

TEST(FootContacts, H36mHasTwoFeetOfAnkleToeAndToeTip) {
  const SkeletonFeet feet = find_feet(Skeleton::h36m());
  ASSERT_EQ(feet.names, (std::vector<std::string>{"RightFoot", "LeftFoot"}));
  EXPECT_EQ(feet.joints[0], (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(feet.joints[1], (std::vector<int>{8, 9, 10}));
}

TEST(FootContacts, PosePositionsAreTheReferenceKinematics) {
  MotionFrames motion = sliding_rest_pose(1, 0);
  for (int c = 3; c < kH36mColumns; ++c) motion.frame(0)[c] = 0.1f * std::sin(static_cast<float>(c));
  const auto ours = pose_positions(Skeleton::h36m(), motion.frame(0));
  const auto reference = test::h36m_positions_mm(motion.frame(0));
  ASSERT_EQ(ours.size(), reference.size());
  for (size_t j = 0; j < ours.size(); ++j) {
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(ours[j][a], reference[j][a], 1e-9) << "joint " << j;
  }
}

TEST(FootContacts, FeetPosesAreTheFeetOfEveryFramesPoseAboutItsRoot) {
  MotionFrames motion = sliding_rest_pose(4, 12.0f);
  for (int64_t f = 0; f < 4; ++f) {
    for (int c = 3; c < kH36mColumns; ++c) motion.frame(f)[c] = 0.2f * std::sin(static_cast<float>(c * (f + 1)));
  }
  const FeetPoses poses = feet_poses(Skeleton::h36m(), motion);
  ASSERT_EQ(poses.per_frame, 6u);
  ASSERT_EQ(poses.positions.size(), 4u * 6u);
  for (int64_t f = 0; f < 4; ++f) {
    const auto whole = pose_positions(Skeleton::h36m(), motion.frame(f));  // every joint, nothing skipped
    for (size_t k = 0; k < 2; ++k) {
      for (size_t i = 0; i < 3; ++i) {
        const int j = poses.feet.joints[k][i];
        for (int a = 0; a < 3; ++a) EXPECT_EQ(poses.at(f, k, i)[a], whole[static_cast<size_t>(j)][a]) << f << " " << j;
      }
    }
  }
  // The floor and the settling from them are those worked out afresh.
  const auto legs = feet_and_legs(Skeleton::h36m(), poses.feet);
  EXPECT_EQ(floor_height(poses, motion),
            floor_height(Skeleton::h36m(), poses.feet, world_positions(Skeleton::h36m(), motion, &legs), 4));
  MotionFrames settled = motion, again = motion;
  settle_on_floor(Skeleton::h36m(), settled, 2);
  settle_on_floor(poses, again, 2);
  EXPECT_EQ(settled.values, again.values);
}

TEST(FootContacts, TheRootHeightPutsTheLowestFootOnTheFloor) {
  MotionFrames motion = sliding_rest_pose(3, 0);
  motion.frame(2)[3 + 3 * 2] = 0.8f;  // frame 2 bends the right knee: the left foot is lowest there
  place_root_on_floor(Skeleton::h36m(), motion);
  // The rest pose's feet hang 897.1 mm below the hips (442.9 + 454.2).
  EXPECT_NEAR(motion.frame(0)[1], 897.1, 0.1);
  EXPECT_NEAR(motion.frame(1)[1], 0.0, 1e-3);
  const auto world = world_positions(Skeleton::h36m(), motion);
  double lowest = 1e9;
  for (int j : {3, 4, 5, 8, 9, 10}) lowest = std::min(lowest, world[static_cast<size_t>(2 * 32 + j)][1]);
  EXPECT_NEAR(lowest, 0.0, 1e-3);
  // A stream placed in two parts reaches the same heights.
  MotionFrames first = sliding_rest_pose(2, 0), second = sliding_rest_pose(1, 0);
  second.frame(0)[3 + 3 * 2] = 0.8f;
  const double height = place_root_on_floor(Skeleton::h36m(), first);
  place_root_on_floor(Skeleton::h36m(), second, height);
  EXPECT_NEAR(first.frame(0)[1] + first.frame(1)[1] + second.frame(0)[1],
              motion.frame(0)[1] + motion.frame(1)[1] + motion.frame(2)[1], 1e-3);
}

TEST(FootContacts, AFootOnTheFloorIsPlantedWhenSlowAndSkatesWhenFast) {
  MotionFrames slow = sliding_rest_pose(50, 4.0f);  // 100 mm/s at 25 Hz
  place_root_on_floor(Skeleton::h36m(), slow);
  for (const uint8_t planted : foot_contacts(Skeleton::h36m(), slow, 25)) EXPECT_EQ(planted, 3);
  EXPECT_EQ(skating_ratio(Skeleton::h36m(), slow, 25).skating, 0);
  MotionFrames fast = sliding_rest_pose(50, 20.0f);  // 500 mm/s: skating, still planted (< 1 m/s)
  place_root_on_floor(Skeleton::h36m(), fast);
  const SkatingCount skating = skating_ratio(Skeleton::h36m(), fast, 25);
  EXPECT_EQ(skating.frames, 49);
  EXPECT_EQ(skating.skating, 49);
  EXPECT_DOUBLE_EQ(skating.ratio(), 1.0);
  MotionFrames flying = sliding_rest_pose(50, 60.0f);  // 1.5 m/s: not planted
  place_root_on_floor(Skeleton::h36m(), flying);
  EXPECT_EQ(foot_contacts(Skeleton::h36m(), flying, 25)[10], 0);
}

TEST(FootContacts, PlantingTheFeetStopsTheSlideOnlyWherAFootIsPlanted) {
  MotionFrames motion = sliding_rest_pose(50, 20.0f);
  // Frames 20..29 lift both feet 200 mm (the root rises): nothing planted there.
  for (int64_t f = 20; f < 30; ++f) motion.frame(f)[1] = f == 20 ? 200.0f : 0.0f;
  motion.frame(30)[1] = -200.0f;
  plant_feet(Skeleton::h36m(), motion, 25);
  for (int64_t f = 1; f < 50; ++f) {
    const bool lifted = f >= 20 && f < 30;
    EXPECT_NEAR(motion.frame(f)[0], lifted ? 20.0f : 0.0f, 1e-4) << "frame " << f;
  }
  EXPECT_EQ(skating_ratio(Skeleton::h36m(), motion, 25).skating, 0);
}

TEST(FootContacts, PhasesKeepTheWholeRootPathOfTheFramesBetween) {
  MotionFrames motion = sliding_rest_pose(7, 3.0f);
  const auto phases = split_phases_keeping_root_path(motion, 2);
  ASSERT_EQ(phases[0].frame_count(), 4);
  ASSERT_EQ(phases[1].frame_count(), 3);
  EXPECT_EQ(phases[0].frame(0)[0], 0.0f);
  for (int64_t k = 1; k < 4; ++k) EXPECT_FLOAT_EQ(phases[0].frame(k)[0], 6.0f);
  for (int64_t k = 1; k < 3; ++k) EXPECT_FLOAT_EQ(phases[1].frame(k)[0], 6.0f);
}

TEST(FootContacts, ARigFromBvhHasTheFeetItsNamesSay) {
  Skeleton rig;
  rig.name = "rig";
  rig.joints = {{"hip", -1, {0, 0, 0}},        {"lThigh", 0, {100, 0, 0}}, {"lShin", 1, {0, -400, 0}},
                {"lFoot", 2, {0, -400, 0}},    {"lFoot_End", 3, {0, -50, 100}}, {"rThigh", 0, {-100, 0, 0}},
                {"rShin", 5, {0, -400, 0}},    {"rFoot", 6, {0, -400, 0}},  {"chest", 0, {0, 300, 0}}};
  const SkeletonFeet feet = find_feet(rig);
  ASSERT_EQ(feet.names, (std::vector<std::string>{"lFoot", "rFoot"}));
  EXPECT_EQ(feet.joints[0], (std::vector<int>{3, 4}));
  EXPECT_EQ(feet.joints[1], (std::vector<int>{7}));
  MotionFrames standing;
  standing.columns = skeleton_motion_columns(rig);
  standing.values.assign(static_cast<size_t>(standing.columns), 0.0f);
  place_root_on_floor(rig, standing);
  EXPECT_NEAR(standing.frame(0)[1], 850.0, 1e-3);  // the End Site hangs lowest
}

}  // namespace
}  // namespace mm
