// The root's path of a rig read from BVH (root_path.h, kHeadingMoves), on a
// real CMU dance: moves in the heading's axes go back to the world exactly,
// and do not depend on which way the dancer faces.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "format/bvh_file.h"
#include "format/root_path.h"
#include "format/skeleton_bvh.h"
#include "tests/common/cmu_dance.h"

namespace mm {
namespace {

MotionFrames dance(const Skeleton& skeleton, const std::string& relative) {
  const std::string path = (test::cmu_dance_dir() / relative).string();
  return skeleton_motion_from_bvh(skeleton, read_bvh_file(path), path);
}

Skeleton dance_skeleton() {
  const std::string path = (test::cmu_dance_dir() / "martial/03.bvh").string();
  return bvh_skeleton(read_bvh_file(path), "dances", 10.0);  // the files are in cm
}

TEST(RootPath, ARigReadFromBvhGetsHeadingMovesAndH36mRootChanges) {
  EXPECT_EQ(trajectory_frame_of(dance_skeleton()), TrajectoryFrame::kHeadingMoves);
  EXPECT_EQ(trajectory_frame_of(Skeleton::h36m()), TrajectoryFrame::kRootChanges);
}

TEST(RootPath, HeadingMovesOfADanceIntegrateBackToItsWorldPath) {
  const Skeleton skeleton = dance_skeleton();
  const MotionFrames world = dance(skeleton, "martial/03.bvh");
  ASSERT_GT(world.frame_count(), 100);
  MotionFrames moves = world;
  heading_moves_from_world(moves);
  // The dancer turns: the heading moves differ from the world's.
  double differs = 0;
  for (int64_t f = 1; f < world.frame_count(); ++f) {
    differs = std::max(differs, static_cast<double>(std::fabs(moves.frame(f)[0] - world.frame(f)[0])));
  }
  EXPECT_GT(differs, 1.0) << "mm";
  RootPathIntegrator(2.0, TrajectoryFrame::kHeadingMoves).integrate(moves);
  for (int64_t f = 1; f < world.frame_count(); ++f) {
    for (int c = 0; c < 6; ++c) ASSERT_NEAR(moves.frame(f)[c], world.frame(f)[c], 1e-2) << "frame " << f << " column " << c;
  }
}

TEST(RootPath, TheSameDanceFacingElsewhereHasTheSameHeadingMoves) {
  const Skeleton skeleton = dance_skeleton();
  const MotionFrames world = dance(skeleton, "indian/04.bvh");
  // The whole dance turned by 70 degrees about +y: its moves and its root
  // orientation (row vectors: R' = R T for the world turn T).
  const double angle = 70.0 * M_PI / 180.0;
  const Mat3 turn = transpose(axis_rotation(1, angle));
  MotionFrames turned = world;
  for (int64_t f = 0; f < turned.frame_count(); ++f) {
    float* frame = turned.frame(f);
    const Vec3 move = multiply(Vec3{frame[0], frame[1], frame[2]}, turn);
    const Vec3 orientation = matrix_to_expmap(multiply(expmap_to_matrix({frame[3], frame[4], frame[5]}), turn));
    for (int a = 0; a < 3; ++a) {
      frame[a] = static_cast<float>(move[static_cast<size_t>(a)]);
      frame[3 + a] = static_cast<float>(orientation[static_cast<size_t>(a)]);
    }
  }
  MotionFrames a = world, b = turned;
  heading_moves_from_world(a);
  heading_moves_from_world(b);
  for (int64_t f = 1; f < a.frame_count(); ++f) {
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(a.frame(f)[c], b.frame(f)[c], 0.05) << "frame " << f << " column " << c;
  }
}

}  // namespace
}  // namespace mm
