// Feet on the floor: which joints are the feet, where the floor is, when a
// foot is planted, how much the feet skate, and the two things a generated
// motion needs to stand on the floor: a root height that follows the poses
// and a root path corrected so that planted feet stay where they were put.
//
// Motions are in the exponential-map layout of their skeleton
// (skeleton_bvh.h): columns 0..2 are the change of the root position since
// the previous frame in mm, and the root's path is their running sum (as the
// BVH export writes it). Poses are placed on that path by forward kinematics
// with the skeleton's row-vector convention (forward_kinematics.h). The
// vertical axis is +y, the skeleton's up (H3.6M's legs hang along -y; BVH
// rigs are Y-up); the floor is horizontal.
//
// Torch-free and reentrant: pure functions over value types.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "format/rotation_matrix.h"
#include "format/skeleton.h"

namespace mm {

// The thresholds that say when a foot is near the floor, planted and
// skating. Defaults are in the range the motion-synthesis literature uses
// (5 cm; a few tenths of a metre a second) and were checked against
// H3.6M's own S5 walking, where they call planted what an animator would.
struct FootContactThresholds {
  // A foot is near the floor when its lowest joint is at most this high
  // above the floor (mm).
  double near_floor_mm = 20.0;
  // A foot near the floor whose joints move horizontally slower than this
  // (mm/s) is planted: what foot_contacts() reports and plant_feet() pins.
  double planted_speed_mm_s = 1000.0;
  // A foot near the floor that moves horizontally faster than this (mm/s)
  // skates (skating_ratio()).
  double skating_speed_mm_s = 300.0;
};

// The feet of a skeleton: per foot, its joints (indices into
// skeleton.joints), every joint whose name holds "foot", "toe" or "ankle"
// (any case) with the joints below it (End Sites included). Feet are told
// apart by the child of the root their leg hangs from (H3.6M's RightUpLeg
// and LeftUpLeg), in the order of the skeleton's joints; `names` holds the
// first foot joint of each ("RightFoot", "LeftFoot"). A skeleton without
// such joints has no feet.
struct SkeletonFeet {
  std::vector<std::vector<int>> joints;
  std::vector<std::string> names;
  bool empty() const { return joints.empty(); }
};
SkeletonFeet find_feet(const Skeleton& skeleton);

// Forward kinematics of one frame's pose about its root (what
// pose_positions gives), set up once for a skeleton and the joints flagged
// in `only` (all without it; every flagged joint's parent flagged with it):
// frame after frame it allocates nothing and works out no rotation that no
// flagged joint below reads. Copyable; one thread at a time (it keeps its
// scratch rotations).
class PoseKinematics {
 public:
  explicit PoseKinematics(const Skeleton& skeleton, const std::vector<bool>* only = nullptr);
  // Writes the flagged joints' positions (mm, the root at the origin) of
  // `frame` (skeleton_motion_columns values) into positions[j], an array of
  // joint_count() entries; the others are left as they are.
  void place(const float* frame, Vec3* positions);

 private:
  std::vector<int> joints_;       // the flagged joints, parents first
  std::vector<int> parents_;      // per joint
  std::vector<Vec3> offsets_;     // per joint, mm
  std::vector<bool> turned_;      // per joint: a flagged child reads its rotation
  std::vector<Mat3> rotations_;   // per joint, scratch: its rotation in the root's frame
};

// Joint positions (mm) of one frame's pose with the root at the origin:
// joint_count() entries. `frame` holds skeleton_motion_columns(skeleton)
// values; the root translation columns are ignored. With `only` (one flag
// per joint, every joint's parent flagged with it), the other joints are
// left at the origin and cost nothing.
std::vector<Vec3> pose_positions(const Skeleton& skeleton, const float* frame,
                                 const std::vector<bool>* only = nullptr);

// Joint positions of every frame on the root's path (the running sum of
// columns 0..2): frames x joint_count() positions, frame-major; `only` as
// for pose_positions.
std::vector<Vec3> world_positions(const Skeleton& skeleton, const MotionFrames& motion,
                                  const std::vector<bool>* only = nullptr);

// The flags of `only` for the feet and the joints above them: all that the
// functions below read, a third of H3.6M's joints.
std::vector<bool> feet_and_legs(const Skeleton& skeleton, const SkeletonFeet& feet);

// The floor's height (mm) under a motion: the 5th percentile over frames of
// the lowest foot joint's height on the root's path, robust to a frame or
// two of noise and to jumps. 0 for a skeleton without feet.
double floor_height(const Skeleton& skeleton, const SkeletonFeet& feet, const std::vector<Vec3>& world,
                    int64_t frames);

// Every foot joint's position about the root (the pose alone, the root at
// the origin) in every frame of a motion: the one pass of forward
// kinematics over the legs that the floor, settle_on_floor and plant_feet
// read. It stays valid while only the root's moves (columns 0..2) change,
// as they do in those functions; a change of any rotation needs a new one.
struct FeetPoses {
  SkeletonFeet feet;
  std::vector<size_t> first;    // per foot, its first joint's place in a frame's entries
  size_t per_frame = 0;         // the joints of all feet
  std::vector<Vec3> positions;  // frames x per_frame, foot by foot in feet.joints' order
  const Vec3& at(int64_t frame, size_t foot, size_t joint) const {
    return positions[static_cast<size_t>(frame) * per_frame + first[foot] + joint];
  }
};
FeetPoses feet_poses(const Skeleton& skeleton, const MotionFrames& motion);

// floor_height of `motion` on its root path as it is now, from its feet's
// poses: no forward kinematics.
double floor_height(const FeetPoses& poses, const MotionFrames& motion);

// Per frame, one bit per foot (bit k: feet.joints[k]) set when that foot is
// planted: near the floor and moving slower than planted_speed_mm_s. A
// foot's height and speed are those of its lowest joint, the point it
// stands on (its speed at frame f: that joint's horizontal displacement
// from frame f-1; frame 1's for frame 0). `rate_hz` is the motion's rate.
std::vector<uint8_t> foot_contacts(const Skeleton& skeleton, const MotionFrames& motion, double rate_hz,
                                   const FootContactThresholds& thresholds = {});

// Counts of skating_ratio(): frames with a foot that skates, of `frames`
// (a motion's frames but its first, which has no speed).
struct SkatingCount {
  int64_t skating = 0;
  int64_t frames = 0;
  double ratio() const { return frames > 0 ? static_cast<double>(skating) / static_cast<double>(frames) : 0.0; }
};
// The frames (from the second on) in which some foot near the floor moves
// horizontally faster than skating_speed_mm_s.
SkatingCount skating_ratio(const Skeleton& skeleton, const MotionFrames& motion, double rate_hz,
                           const FootContactThresholds& thresholds = {});

// Sets the root's height (the running sum of column 1) to what puts the
// lowest foot joint of every frame on the floor at height 0: frame 0's
// column 1 becomes that height less `height_before` (the height the running
// sum has reached before this motion: 0 for a whole motion, the returned
// value of the previous call for the next part of a stream), later frames'
// the change from the frame before. Returns the last frame's height. A
// skeleton without feet is left alone (returns height_before). For
// generated motion, whose poses say how high the hips are but not where
// the floor is.
double place_root_on_floor(const Skeleton& skeleton, MotionFrames& motion, double height_before = 0);

// Keeps a motion's feet on the floor at y = 0 without flattening its steps:
// the root's height is shifted by a slowly varying offset, the negated 5th
// percentile of the lowest foot joint's height over the `window` frames on
// each side, averaged over half that window on each side. A path whose
// vertical moves drift (a generated one, integrated) neither sinks nor
// floats, while the body's rise and fall within a step stays. Returns
// nothing; columns 1 (the root's height changes) are rewritten.
void settle_on_floor(const Skeleton& skeleton, MotionFrames& motion, int window = 25);
// The same from the motion's feet poses (feet_poses(), or what
// integrate_level_root_path returns): no forward kinematics.
void settle_on_floor(const FeetPoses& poses, MotionFrames& motion, int window = 25);

// settle_on_floor for a stream that is never held whole (a take's reply):
// the stream's vertical moves are dropped, and the root's height follows
// the 5th percentile of the lowest foot's height over the last `window`
// frames, smoothed over about half as many, so that it carries on from one
// part of the stream to the next without a step. The first frame starts on
// the floor. Used by one thread at a time.
class StreamingFloor {
 public:
  explicit StreamingFloor(const Skeleton& skeleton, int window = 50);
  // Rewrites column 1 (the root's height changes) of the next frames.
  void settle(MotionFrames& frames);

 private:
  SkeletonFeet feet_;
  PoseKinematics legs_;
  std::vector<Vec3> pose_;  // one frame's joints, of which the feet's are placed
  int window_;
  Vec3 root_{0, 0, 0};         // the root as given, before any offset
  std::vector<double> recent_;  // the lowest foot's height, last `window_` frames (a ring)
  size_t next_ = 0;
  int64_t seen_ = 0;
  double wanted_ = 0;  // the negated percentile, taken again every few frames
  double offset_ = 0;
  bool started_ = false;
};

// Removes the skating that remains in a motion's root path: in every frame
// in which a foot is planted (foot_contacts() of the motion as given), the
// root's horizontal change from the frame before is corrected by the mean
// horizontal slip of the planted feet's lowest joints, so that a single
// planted foot stays exactly where it was put. Frames with no planted foot keep their root
// change; heights and poses are untouched. Returns the contacts it used.
std::vector<uint8_t> plant_feet(const Skeleton& skeleton, MotionFrames& motion, double rate_hz,
                                const FootContactThresholds& thresholds = {});

}  // namespace mm
