#include "model/forward_kinematics.h"

#include <gtest/gtest.h>

#include "format/input_error.h"
#include "format/motion_text.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

TEST(ForwardKinematics, RestPoseStacksBoneOffsets) {
  const Skeleton skeleton = Skeleton::h36m();
  ForwardKinematics fk(skeleton);
  auto p = fk.positions(at::zeros({99}, at::kDouble));
  ASSERT_EQ(p.sizes(), (std::vector<int64_t>{32, 3}));
  // Right foot: hip offset + thigh + shin, all along the rest directions.
  EXPECT_NEAR(p[3][0].item<double>(), -132.948591, 1e-6);
  EXPECT_NEAR(p[3][1].item<double>(), -442.894612 - 454.206447, 1e-6);
  EXPECT_NEAR(p[15][1].item<double>(), 0.1 + 233.383263 + 257.077681 + 121.134938 + 115.002227, 1e-6);
}

TEST(ForwardKinematics, RotatingAJointMovesOnlyItsDescendants) {
  ForwardKinematics fk(Skeleton::h36m());
  auto frame = at::zeros({99}, at::kDouble);
  // A quarter turn of RightUpLeg (joint 1) about z swings the shin's offset.
  frame[3 + 3 * 1 + 2] = M_PI / 2;
  auto p = fk.positions(frame);
  auto rest = fk.positions(at::zeros({99}, at::kDouble));
  EXPECT_TRUE(at::allclose(p[1], rest[1]));                        // the joint itself stays
  EXPECT_TRUE(at::allclose(p.slice(0, 6), rest.slice(0, 6)));       // left leg and upper body unchanged
  const double knee_distance = (p[2] - p[1]).norm().item<double>();
  EXPECT_NEAR(knee_distance, 442.894612, 1e-6);                     // bone length kept
  EXPECT_NEAR(std::abs(p[2][0].item<double>() - p[1][0].item<double>()), 442.894612, 1e-6);  // now sideways
}

TEST(ForwardKinematics, RealFramesKeepBoneLengths) {
  MM_REQUIRE_H36M();
  const Skeleton skeleton = Skeleton::h36m();
  auto motion = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  auto frames = at::from_blob(motion.values.data(), {motion.frame_count(), 99}).to(at::kDouble);
  auto p = ForwardKinematics(skeleton).positions(frames.slice(0, 0, 100));
  for (int j = 1; j < skeleton.joint_count(); ++j) {
    const auto& joint = skeleton.joints[j];
    const double bone = std::sqrt(joint.offset_mm[0] * joint.offset_mm[0] + joint.offset_mm[1] * joint.offset_mm[1] +
                                  joint.offset_mm[2] * joint.offset_mm[2]);
    auto lengths = (p.select(1, j) - p.select(1, joint.parent)).norm(2, -1);
    EXPECT_TRUE(at::allclose(lengths, at::full_like(lengths, bone), 1e-6, 1e-6)) << joint.name;
  }
}

TEST(ForwardKinematics, RejectsFramesOfTheWrongWidth) {
  ForwardKinematics fk(Skeleton::h36m());
  try {
    fk.positions(at::zeros({5, 98}));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 99"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("found 98"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mm
