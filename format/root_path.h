// The root's path in the world for motion whose root columns hold changes
// in the root's own frame, as the H3.6M text layout records them: columns
// 0..2 the root's move since the previous frame in the previous frame's
// root axes (mm), columns 3..5 the root's rotation since the previous frame
// (an exponential map). The H3.6M files hold these at 50 Hz, and the model
// keeps every second frame, so at 25 Hz each frame's rotation change stands
// for two of its 50 Hz steps (`rotation_steps` 2; 50 / rate in general).
//
// In world layout (what a BVH export, three.js or an engine reads, and what
// the other functions of format/ take: skeleton_bvh.h, foot_contacts.h)
// columns 0..2 are the root's move in world axes and columns 3..5 its world
// orientation. A body rotates its pelvis by several degrees each step, so
// reading the changes as an orientation (the pelvis never turning) makes
// planted feet slide at about half the walking speed; integrated, they stay
// within a few cm/s.
//
// Rotations use the row-vector convention of format/rotation_matrix.h: the
// orientation after a frame is R_f = D_f^steps R_(f-1), and the move is
// d_f R_(f-1), as in the reference visualisation of the data set.
//
// Thread safety: pure functions, and an integrator used by one thread.
#pragma once

#include "format/foot_contacts.h"
#include "format/motion_frames.h"
#include "format/rotation_matrix.h"
#include "format/skeleton.h"

namespace mm {

// What a generated root is made of, chosen by how a skeleton's recordings
// hold their root:
// - kRootChanges: H3.6M's text files hold changes in the root's own frame
//   (above): the trajectory network predicts each frame's move and turn,
//   and they are integrated into world layout.
// - kHeadingMoves: a rig read from BVH (Skeleton::bvh set, bvh_skeleton())
//   holds its root in world layout from the start, its orientation a joint
//   rotation that the manifold models with the pose. The network predicts
//   the move alone, in the axes of the previous frame's heading (the turn
//   about +y, BVH's up, closest to the root's orientation), so that a step
//   forward reads the same whichever way the body faces; the orientation
//   stays the decoded one.
enum class TrajectoryFrame { kRootChanges, kHeadingMoves };
TrajectoryFrame trajectory_frame_of(const Skeleton& skeleton);

// The heading of a root orientation (an exponential map, row vectors, world
// layout): the angle in radians of the turn about +y closest to it.
double heading_radians(const float* orientation);

// World layout's moves to heading moves, in place: each frame's columns
// 0..2 turned by minus the previous frame's heading about +y (frame 0's
// by its own); columns 3.. unchanged. What the network learns for
// kHeadingMoves; RootPathIntegrator undoes it.
void heading_moves_from_world(MotionFrames& motion);

// Integrates a stream of frames into world layout, in place, continuing
// from where the previous call ended. kRootChanges: from root-change layout
// (the first frame's orientation starts from the identity). kHeadingMoves:
// from heading moves, each turned by the previous frame's heading, columns
// 3..5 left as they are. The first frame of the stream moves nowhere.
class RootPathIntegrator {
 public:
  explicit RootPathIntegrator(double rotation_steps, TrajectoryFrame frame = TrajectoryFrame::kRootChanges);
  void integrate(MotionFrames& motion);

 private:
  double rotation_steps_;
  TrajectoryFrame frame_;
  Mat3 orientation_;
  double heading_ = 0;
  bool started_ = false;
};

// The inverse of the integration: a motion in world layout back in the
// root-change layout the model reads (each frame's move in the previous
// frame's root axes, its rotation change as `rotation_steps` equal steps),
// so that a generated motion can be encoded again. Frame 0 keeps no move
// (where the root started is not a change) and its orientation as its
// rotation change.
void root_changes_from_world(MotionFrames& motion, double rotation_steps);

// A motion in world layout (a generated one sent back) as the model of
// `skeleton` reads it: root_changes_from_world for kRootChanges; a rig's
// world layout is already its model's, and stays as it is.
void model_root_from_world(const Skeleton& skeleton, MotionFrames& motion, double rotation_steps);

// A whole clip to world layout, levelled and on the floor: integrated as
// above, then turned about the origin so that its up is +y, and raised so
// that the floor (foot_contacts.h's floor_height) is at y = 0: frame 0's
// columns 0..2 hold the root's start (0, height, 0).
//
// Up: the data set's root frame is the pelvis's, tilted by a few degrees,
// and nothing records the tilt of the first frame; the up is taken as the
// mean of the pelvis's up axis over the clip made perpendicular to the
// directions the root travels in (the path lies on a floor), so that a
// walk neither climbs nor sinks.
//
// Returns the feet's poses the floor was found from (empty for a skeleton
// without feet), for settle_on_floor to reuse.
FeetPoses integrate_level_root_path(const Skeleton& skeleton, MotionFrames& motion, double rotation_steps);

}  // namespace mm
