// A motion's mirror image (motion_mirror.h), checked by forward kinematics
// on real motion: every joint of the mirrored pose lies where its twin of
// the recorded pose lies reflected across the body's plane, for H3.6M and
// for a CMU dance rig read from BVH; the root turns the other way; and the
// map on normalised frames the trainer uses is the mirror of the
// denormalised frame.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "format/bvh_file.h"
#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "format/motion_mirror.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

MotionFrames every_nth(const MotionFrames& motion, int64_t step) {
  MotionFrames out;
  out.columns = motion.columns;
  for (int64_t f = 0; f < motion.frame_count(); f += step) {
    out.values.insert(out.values.end(), motion.frame(f), motion.frame(f) + motion.columns);
  }
  return out;
}

// The twin of each joint, read off the mirror's columns.
int twin_of(const MotionMirror& mirror, int joint) { return (mirror.source_column[static_cast<size_t>(3 + 3 * joint)] - 3) / 3; }

// The largest distance (mm) between a mirrored pose's joints and their
// twins' reflected positions in the recorded pose, over the frames and the
// joints some bone hangs from (end points' offsets may differ between the
// sides).
double largest_reflection_error(const Skeleton& skeleton, const MotionMirror& mirror, const MotionFrames& motion) {
  const MotionFrames flipped = mirrored(mirror, motion);
  std::vector<bool> leaf(static_cast<size_t>(skeleton.joint_count()), true);
  for (const Joint& joint : skeleton.joints) {
    const bool bone = joint.offset_mm[0] != 0 || joint.offset_mm[1] != 0 || joint.offset_mm[2] != 0;
    if (joint.parent >= 0 && bone) leaf[static_cast<size_t>(joint.parent)] = false;
  }
  double largest = 0;
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    const auto recorded = pose_positions(skeleton, motion.frame(f));
    const auto mirror_pose = pose_positions(skeleton, flipped.frame(f));
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      if (leaf[static_cast<size_t>(j)]) continue;
      Vec3 expected = recorded[static_cast<size_t>(j)];
      expected[static_cast<size_t>(mirror.lateral_axis)] *= -1;
      const Vec3& got = mirror_pose[static_cast<size_t>(twin_of(mirror, j))];
      double d = 0;
      for (int a = 0; a < 3; ++a) d += (got[a] - expected[a]) * (got[a] - expected[a]);
      largest = std::max(largest, std::sqrt(d));
    }
  }
  return largest;
}

TEST(MotionMirror, H36mPosesMirroredLieWhereTheirTwinsLieReflected) {
  MM_REQUIRE_H36M();
  const Skeleton skeleton = Skeleton::h36m();
  const MotionMirror mirror = motion_mirror(skeleton);
  EXPECT_EQ(mirror.lateral_axis, 0);  // x: the hips are at -133 and +133 mm
  EXPECT_EQ(twin_of(mirror, 1), 6);   // RightUpLeg, LeftUpLeg
  EXPECT_EQ(twin_of(mirror, 17), 25); // LeftArm, RightArm
  EXPECT_EQ(twin_of(mirror, 12), 12); // Spine1
  const MotionFrames walk = every_nth(read_motion_text((test::h36m_dataset_dir() / "S1" / "walking_1.txt").string()), 50);
  // The skeleton's own asymmetries are under 0.01 mm but for the arms'
  // bones (151.034 and 151.031 mm; 278.883 and 278.893 mm).
  const double error = largest_reflection_error(skeleton, mirror, walk);
  std::printf("largest distance from the reflected twin: %.4f mm over %lld frames\n", error,
              static_cast<long long>(walk.frame_count()));
  EXPECT_LT(error, 0.1);
  // The root turns and moves sideways the other way.
  const MotionFrames flipped = mirrored(mirror, walk);
  for (int64_t f = 0; f < walk.frame_count(); ++f) {
    EXPECT_EQ(flipped.frame(f)[4], -walk.frame(f)[4]);  // the turn about the up axis
    EXPECT_EQ(flipped.frame(f)[0], -walk.frame(f)[0]);  // the sideways move
    EXPECT_EQ(flipped.frame(f)[2], walk.frame(f)[2]);   // the forward move
  }
  // Twice is the motion itself.
  EXPECT_EQ(mirrored(mirror, flipped).values, walk.values);
}

TEST(MotionMirror, ADanceRigReadFromBvhMirrorsToo) {
  const std::string path = (test::cmu_dance_dir() / "martial/03.bvh").string();
  const BvhFile file = read_bvh_file(path);
  const Skeleton skeleton = bvh_skeleton(file, "dances", 10.0);
  const MotionMirror mirror = motion_mirror(skeleton);
  const MotionFrames dance = every_nth(skeleton_motion_from_bvh(skeleton, file, path), 40);
  const double error = largest_reflection_error(skeleton, mirror, dance);
  std::printf("dance rig: lateral axis %d, largest distance %.4f mm\n", mirror.lateral_axis, error);
  EXPECT_LT(error, 20.0);  // the rig's own sides differ by a few mm a bone
}

TEST(MotionMirror, NormalisedFramesMirrorAsTheirMotionDoes) {
  MM_REQUIRE_H36M();
  const MotionMirror mirror = motion_mirror(Skeleton::h36m());
  const MotionFrames walk = every_nth(read_motion_text((test::h36m_dataset_dir() / "S1" / "walking_1.txt").string()), 10);
  const MotionFrames sit = every_nth(read_motion_text((test::h36m_dataset_dir() / "S1" / "sitting_1.txt").string()), 10);
  const PoseNormalization normalization = PoseNormalization::fit({&walk, &sit});
  const NormalizedMirror map = normalized_mirror(mirror, normalization);
  ASSERT_EQ(static_cast<int>(map.source_dim.size()), normalization.dims());
  const MotionFrames normalized = normalization.normalize(walk);
  const MotionFrames expected = normalization.normalize(mirrored(mirror, normalization.denormalize(normalized)));
  double largest = 0;
  for (int64_t f = 0; f < normalized.frame_count(); ++f) {
    for (int d = 0; d < normalization.dims(); ++d) {
      const float got = map.scale[static_cast<size_t>(d)] * normalized.frame(f)[map.source_dim[static_cast<size_t>(d)]] +
                        map.shift[static_cast<size_t>(d)];
      largest = std::max(largest, static_cast<double>(std::fabs(got - expected.frame(f)[d])));
    }
  }
  EXPECT_LT(largest, 1e-4);
}

TEST(MotionMirror, ASkeletonThatIsNotItsOwnMirrorImageIsRefusedNamingTheJoint) {
  Skeleton skeleton = Skeleton::h36m();
  skeleton.joints[7].offset_mm[1] = -400;  // LeftLeg shorter than RightLeg by 43 mm
  try {
    motion_mirror(skeleton);
    FAIL() << "an asymmetric skeleton was mirrored";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("RightLeg"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("mirror image"), std::string::npos) << error.what();
  }
  skeleton = Skeleton::h36m();
  skeleton.joints[6].name = "LeftHip";  // RightUpLeg has no twin now
  EXPECT_THROW(motion_mirror(skeleton), InputError);
}

}  // namespace
}  // namespace mm
