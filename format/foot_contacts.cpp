#include "format/foot_contacts.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace mm {
namespace {

bool names_a_foot(const std::string& name) {
  std::string lower(name.size(), ' ');
  std::transform(name.begin(), name.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return lower.find("foot") != std::string::npos || lower.find("toe") != std::string::npos ||
         lower.find("ankle") != std::string::npos;
}

// The child of the root that joint j hangs from (j itself when it is one).
int leg_of(const Skeleton& skeleton, int j) {
  while (j > 0 && skeleton.joints[static_cast<size_t>(j)].parent > 0) j = skeleton.joints[static_cast<size_t>(j)].parent;
  return j;
}

double horizontal_distance(const Vec3& a, const Vec3& b) { return std::hypot(a[0] - b[0], a[2] - b[2]); }

// The root's position in every frame: the running sum of columns 0..2.
std::vector<Vec3> root_positions(const MotionFrames& motion) {
  std::vector<Vec3> roots(static_cast<size_t>(motion.frame_count()));
  Vec3 root{0, 0, 0};
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    for (int a = 0; a < 3; ++a) root[static_cast<size_t>(a)] += motion.frame(f)[a];
    roots[static_cast<size_t>(f)] = root;
  }
  return roots;
}

// A foot joint on the root's path, added as world_positions adds them.
Vec3 in_world(const Vec3& pose, const Vec3& root) { return {pose[0] + root[0], pose[1] + root[1], pose[2] + root[2]}; }

// Per frame and foot: the lowest joint's height and that joint's
// horizontal displacement since the frame before (frame 1's for frame 0):
// the point the foot stands on, which stays put while the heel lifts and
// the foot rolls over its toes.
struct FootTracks {
  std::vector<double> lowest;    // frames x feet
  std::vector<double> movement;  // frames x feet, mm per frame
  std::vector<size_t> joint;     // frames x feet: which of the foot's joints is lowest
};

// The foot's joint lowest at frame f (the first of equals).
size_t lowest_joint(const FeetPoses& poses, size_t foot, const std::vector<Vec3>& roots, int64_t f) {
  size_t lowest = 0;
  double height = poses.at(f, foot, 0)[1] + roots[static_cast<size_t>(f)][1];
  for (size_t i = 1; i < poses.feet.joints[foot].size(); ++i) {
    const double y = poses.at(f, foot, i)[1] + roots[static_cast<size_t>(f)][1];
    if (y < height) {
      lowest = i;
      height = y;
    }
  }
  return lowest;
}

FootTracks track_feet(const FeetPoses& poses, const std::vector<Vec3>& roots) {
  const size_t foot_count = poses.feet.joints.size();
  const auto frames = static_cast<int64_t>(roots.size());
  FootTracks tracks{std::vector<double>(static_cast<size_t>(frames) * foot_count),
                    std::vector<double>(static_cast<size_t>(frames) * foot_count, 0.0),
                    std::vector<size_t>(static_cast<size_t>(frames) * foot_count, 0)};
  for (int64_t f = 0; f < frames; ++f) {
    for (size_t k = 0; k < foot_count; ++k) {
      const size_t i = lowest_joint(poses, k, roots, f);
      const int64_t before = f > 0 ? f - 1 : std::min<int64_t>(1, frames - 1), after = f > 0 ? f : 0;
      const size_t at = static_cast<size_t>(f) * foot_count + k;
      tracks.joint[at] = i;
      tracks.lowest[at] = poses.at(f, k, i)[1] + roots[static_cast<size_t>(f)][1];
      tracks.movement[at] = horizontal_distance(in_world(poses.at(after, k, i), roots[static_cast<size_t>(after)]),
                                                in_world(poses.at(before, k, i), roots[static_cast<size_t>(before)]));
    }
  }
  return tracks;
}

// The lowest foot joint's height in every frame, on the root's path.
std::vector<double> lowest_foot(const FeetPoses& poses, const std::vector<Vec3>& roots) {
  std::vector<double> lowest(roots.size(), std::numeric_limits<double>::infinity());
  for (size_t f = 0; f < roots.size(); ++f) {
    const Vec3* pose = poses.positions.data() + f * poses.per_frame;
    for (size_t i = 0; i < poses.per_frame; ++i) lowest[f] = std::min(lowest[f], pose[i][1] + roots[f][1]);
  }
  return lowest;
}

// The 5th percentile of `heights` (reordered).
double fifth_percentile(std::vector<double>& heights) {
  const auto nth = heights.begin() + static_cast<std::ptrdiff_t>(static_cast<double>(heights.size() - 1) * 0.05);
  std::nth_element(heights.begin(), nth, heights.end());
  return *nth;
}

// A motion's feet, its floor and its feet's tracks: what contacts and
// skating are read from.
struct FeetOnTheFloor {
  SkeletonFeet feet;
  double floor = 0;
  FootTracks tracks;
};

}  // namespace

SkeletonFeet find_feet(const Skeleton& skeleton) {
  SkeletonFeet feet;
  std::vector<int> leg_of_foot;  // per foot, the leg it belongs to
  const int count = skeleton.joint_count();
  std::vector<bool> in_foot(static_cast<size_t>(count), false);
  for (int j = 1; j < count; ++j) {
    const int parent = skeleton.joints[static_cast<size_t>(j)].parent;
    const bool below_foot = parent >= 0 && in_foot[static_cast<size_t>(parent)];
    if (!below_foot && !names_a_foot(skeleton.joints[static_cast<size_t>(j)].name)) continue;
    in_foot[static_cast<size_t>(j)] = true;
    const int leg = leg_of(skeleton, j);
    const auto known = std::find(leg_of_foot.begin(), leg_of_foot.end(), leg);
    if (known == leg_of_foot.end()) {
      leg_of_foot.push_back(leg);
      feet.joints.push_back({j});
      feet.names.push_back(skeleton.joints[static_cast<size_t>(j)].name);
    } else {
      feet.joints[static_cast<size_t>(known - leg_of_foot.begin())].push_back(j);
    }
  }
  return feet;
}

std::vector<bool> feet_and_legs(const Skeleton& skeleton, const SkeletonFeet& feet) {
  std::vector<bool> needed(skeleton.joints.size(), false);
  for (const auto& foot : feet.joints) {
    for (int j : foot) {
      for (int k = j; k >= 0 && !needed[static_cast<size_t>(k)]; k = skeleton.joints[static_cast<size_t>(k)].parent) {
        needed[static_cast<size_t>(k)] = true;
      }
    }
  }
  return needed;
}

PoseKinematics::PoseKinematics(const Skeleton& skeleton, const std::vector<bool>* only) {
  const size_t count = skeleton.joints.size();
  std::vector<bool> flagged(count, only == nullptr);
  for (size_t j = 0; j < count && only; ++j) {
    if (!(*only)[j]) continue;
    // A flagged joint's parents are placed with it, flagged or not.
    for (int k = static_cast<int>(j); k >= 0 && !flagged[static_cast<size_t>(k)]; k = skeleton.joints[static_cast<size_t>(k)].parent) {
      flagged[static_cast<size_t>(k)] = true;
    }
  }
  parents_.resize(count);
  offsets_.resize(count);
  turned_.assign(count, false);
  rotations_.resize(count);
  for (size_t j = 0; j < count; ++j) {
    parents_[j] = skeleton.joints[j].parent;
    offsets_[j] = skeleton.joints[j].offset_mm;
    if (!flagged[j]) continue;
    joints_.push_back(static_cast<int>(j));
    if (parents_[j] >= 0) turned_[static_cast<size_t>(parents_[j])] = true;
  }
}

void PoseKinematics::place(const float* frame, Vec3* positions) {
  for (const int joint : joints_) {
    const auto j = static_cast<size_t>(joint);
    const int parent = parents_[j];
    if (parent < 0) {
      if (turned_[j]) rotations_[j] = expmap_to_matrix({frame[3 + 3 * j], frame[4 + 3 * j], frame[5 + 3 * j]});
      positions[j] = {0, 0, 0};
      continue;
    }
    // Row vectors (the skeleton file's convention): R_world[j] = R_local[j]
    // R_world[parent], p[j] = offset[j] R_world[parent] + p[parent]. A
    // joint no flagged joint hangs from (a toe tip) needs no R_world.
    const auto p = static_cast<size_t>(parent);
    if (turned_[j]) {
      rotations_[j] = multiply(expmap_to_matrix({frame[3 + 3 * j], frame[4 + 3 * j], frame[5 + 3 * j]}), rotations_[p]);
    }
    const Vec3 turned = multiply(offsets_[j], rotations_[p]);
    positions[j] = {turned[0] + positions[p][0], turned[1] + positions[p][1], turned[2] + positions[p][2]};
  }
}

std::vector<Vec3> pose_positions(const Skeleton& skeleton, const float* frame, const std::vector<bool>* only) {
  std::vector<Vec3> positions(skeleton.joints.size(), Vec3{0, 0, 0});
  PoseKinematics(skeleton, only).place(frame, positions.data());
  return positions;
}

std::vector<Vec3> world_positions(const Skeleton& skeleton, const MotionFrames& motion, const std::vector<bool>* only) {
  const int64_t frames = motion.frame_count();
  const size_t count = skeleton.joints.size();
  PoseKinematics kinematics(skeleton, only);
  std::vector<Vec3> pose(count, Vec3{0, 0, 0});
  std::vector<Vec3> world;
  world.reserve(static_cast<size_t>(frames) * count);
  Vec3 root{0, 0, 0};
  for (int64_t f = 0; f < frames; ++f) {
    const float* frame = motion.frame(f);
    for (int a = 0; a < 3; ++a) root[static_cast<size_t>(a)] += frame[a];
    kinematics.place(frame, pose.data());
    for (const Vec3& p : pose) world.push_back(in_world(p, root));
  }
  return world;
}

FeetPoses feet_poses(const Skeleton& skeleton, const MotionFrames& motion) {
  FeetPoses poses;
  poses.feet = find_feet(skeleton);
  for (const auto& foot : poses.feet.joints) {
    poses.first.push_back(poses.per_frame);
    poses.per_frame += foot.size();
  }
  const int64_t frames = motion.frame_count();
  if (poses.feet.empty() || frames < 1) return poses;
  const auto legs = feet_and_legs(skeleton, poses.feet);
  PoseKinematics kinematics(skeleton, &legs);
  std::vector<Vec3> pose(skeleton.joints.size(), Vec3{0, 0, 0});
  poses.positions.resize(static_cast<size_t>(frames) * poses.per_frame);
  Vec3* out = poses.positions.data();
  for (int64_t f = 0; f < frames; ++f) {
    kinematics.place(motion.frame(f), pose.data());
    for (const auto& foot : poses.feet.joints) {
      for (const int j : foot) *out++ = pose[static_cast<size_t>(j)];
    }
  }
  return poses;
}

double floor_height(const FeetPoses& poses, const MotionFrames& motion) {
  if (poses.feet.empty() || motion.frame_count() < 1) return 0.0;
  std::vector<double> lowest = lowest_foot(poses, root_positions(motion));
  return fifth_percentile(lowest);
}

double floor_height(const Skeleton& skeleton, const SkeletonFeet& feet, const std::vector<Vec3>& world,
                    int64_t frames) {
  if (feet.empty() || frames < 1) return 0.0;
  std::vector<double> lowest(static_cast<size_t>(frames), std::numeric_limits<double>::infinity());
  const int count = skeleton.joint_count();
  for (int64_t f = 0; f < frames; ++f) {
    for (const auto& foot : feet.joints) {
      for (int j : foot) lowest[static_cast<size_t>(f)] = std::min(lowest[static_cast<size_t>(f)], world[static_cast<size_t>(f * count + j)][1]);
    }
  }
  return fifth_percentile(lowest);
}

namespace {

// Empty feet for a skeleton without any or a motion of fewer than 2 frames.
FeetOnTheFloor feet_on_the_floor(const FeetPoses& poses, const std::vector<Vec3>& roots) {
  if (poses.feet.empty() || roots.size() < 2) return FeetOnTheFloor{};
  std::vector<double> lowest = lowest_foot(poses, roots);
  return FeetOnTheFloor{poses.feet, fifth_percentile(lowest), track_feet(poses, roots)};
}

FeetOnTheFloor feet_on_the_floor(const Skeleton& skeleton, const MotionFrames& motion) {
  if (motion.frame_count() < 2) return FeetOnTheFloor{};
  return feet_on_the_floor(feet_poses(skeleton, motion), root_positions(motion));
}

std::vector<uint8_t> planted_feet(const FeetOnTheFloor& on, int64_t frames, double rate_hz,
                                  const FootContactThresholds& thresholds) {
  std::vector<uint8_t> contacts(static_cast<size_t>(frames), 0);
  const size_t foot_count = on.feet.joints.size();
  const double planted_mm_per_frame = thresholds.planted_speed_mm_s / rate_hz;
  for (int64_t f = 0; f < frames && foot_count > 0; ++f) {
    for (size_t k = 0; k < foot_count && k < 8; ++k) {
      const size_t at = static_cast<size_t>(f) * foot_count + k;
      if (on.tracks.lowest[at] - on.floor <= thresholds.near_floor_mm && on.tracks.movement[at] < planted_mm_per_frame) {
        contacts[static_cast<size_t>(f)] |= static_cast<uint8_t>(1u << k);
      }
    }
  }
  return contacts;
}

}  // namespace

std::vector<uint8_t> foot_contacts(const Skeleton& skeleton, const MotionFrames& motion, double rate_hz,
                                   const FootContactThresholds& thresholds) {
  return planted_feet(feet_on_the_floor(skeleton, motion), motion.frame_count(), rate_hz, thresholds);
}

SkatingCount skating_ratio(const Skeleton& skeleton, const MotionFrames& motion, double rate_hz,
                           const FootContactThresholds& thresholds) {
  const int64_t frames = motion.frame_count();
  SkatingCount count;
  const FeetOnTheFloor on = feet_on_the_floor(skeleton, motion);
  if (on.feet.empty()) return count;
  const FootTracks& tracks = on.tracks;
  const double floor = on.floor;
  const size_t foot_count = on.feet.joints.size();
  const double skating_mm_per_frame = thresholds.skating_speed_mm_s / rate_hz;
  for (int64_t f = 1; f < frames; ++f) {
    bool skating = false;
    for (size_t k = 0; k < foot_count; ++k) {
      const size_t at = static_cast<size_t>(f) * foot_count + k;
      skating |= tracks.lowest[at] - floor <= thresholds.near_floor_mm && tracks.movement[at] > skating_mm_per_frame;
    }
    count.skating += skating ? 1 : 0;
    ++count.frames;
  }
  return count;
}

double place_root_on_floor(const Skeleton& skeleton, MotionFrames& motion, double height_before) {
  const SkeletonFeet feet = find_feet(skeleton);
  if (feet.empty()) return height_before;
  const auto legs = feet_and_legs(skeleton, feet);
  PoseKinematics kinematics(skeleton, &legs);
  std::vector<Vec3> pose(skeleton.joints.size(), Vec3{0, 0, 0});
  double previous = height_before;
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    float* frame = motion.frame(f);
    kinematics.place(frame, pose.data());
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& foot : feet.joints) {
      for (int j : foot) lowest = std::min(lowest, pose[static_cast<size_t>(j)][1]);
    }
    const double height = -lowest;
    frame[1] = static_cast<float>(height - previous);
    previous += frame[1];  // what the running sum reaches, float rounding included
  }
  return previous;
}

void settle_on_floor(const Skeleton& skeleton, MotionFrames& motion, int window) {
  if (find_feet(skeleton).empty() || motion.frame_count() < 1) return;
  settle_on_floor(feet_poses(skeleton, motion), motion, window);
}

void settle_on_floor(const FeetPoses& poses, MotionFrames& motion, int window) {
  const int64_t frames = motion.frame_count();
  if (poses.feet.empty() || frames < 1) return;
  const std::vector<double> lowest = lowest_foot(poses, root_positions(motion));
  std::vector<double> floor(static_cast<size_t>(frames)), offset(static_cast<size_t>(frames)), near;
  for (int64_t f = 0; f < frames; ++f) {
    const int64_t from = std::max<int64_t>(0, f - window), to = std::min<int64_t>(frames - 1, f + window);
    near.assign(lowest.begin() + from, lowest.begin() + to + 1);
    floor[static_cast<size_t>(f)] = fifth_percentile(near);
  }
  const int half = std::max(1, window / 2);
  for (int64_t f = 0; f < frames; ++f) {
    const int64_t from = std::max<int64_t>(0, f - half), to = std::min<int64_t>(frames - 1, f + half);
    double sum = 0;
    for (int64_t g = from; g <= to; ++g) sum += floor[static_cast<size_t>(g)];
    offset[static_cast<size_t>(f)] = -sum / static_cast<double>(to - from + 1);
  }
  for (int64_t f = frames - 1; f >= 0; --f) {
    const double before = f > 0 ? offset[static_cast<size_t>(f - 1)] : 0.0;
    motion.frame(f)[1] += static_cast<float>(offset[static_cast<size_t>(f)] - before);
  }
}

namespace {

PoseKinematics legs_of(const Skeleton& skeleton, const SkeletonFeet& feet) {
  const auto legs = feet_and_legs(skeleton, feet);
  return PoseKinematics(skeleton, &legs);
}

}  // namespace

StreamingFloor::StreamingFloor(const Skeleton& skeleton, int window)
    : feet_(find_feet(skeleton)),
      legs_(legs_of(skeleton, feet_)),
      pose_(skeleton.joints.size(), Vec3{0, 0, 0}),
      window_(std::max(1, window)) {}

void StreamingFloor::settle(MotionFrames& frames) {
  if (feet_.empty()) return;
  const double smoothing = 2.0 / (window_ / 2.0 + 1.0);  // an exponential average over about window / 2 frames
  for (int64_t f = 0; f < frames.frame_count(); ++f) {
    float* frame = frames.frame(f);
    // The stream's own vertical moves are dropped: integrated, they drift
    // faster than a window behind the frame can follow (on 20 s of S5
    // walking the lowest foot ranged from 157 mm below the floor to 498 mm
    // above it), so the height is the floor's offset alone.
    frame[1] = 0.0f;
    for (int a = 0; a < 3; ++a) root_[static_cast<size_t>(a)] += frame[a];
    legs_.place(frame, pose_.data());
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& foot : feet_.joints) {
      for (int j : foot) lowest = std::min(lowest, pose_[static_cast<size_t>(j)][1]);
    }
    lowest += root_[1];
    if (recent_.size() < static_cast<size_t>(window_)) {
      recent_.push_back(lowest);
    } else {
      recent_[next_] = lowest;
      next_ = (next_ + 1) % recent_.size();
    }
    // The percentile over the window is taken again about 50 times a
    // window, so that a take at 1000 Hz (a 2,000-frame window) costs per
    // frame what one at 50 Hz does.
    if (seen_++ % std::max(1, window_ / 50) == 0) {
      std::vector<double> sorted = recent_;
      const auto nth = sorted.begin() + static_cast<std::ptrdiff_t>(static_cast<double>(sorted.size() - 1) * 0.05);
      std::nth_element(sorted.begin(), nth, sorted.end());
      wanted_ = -*nth;
    }
    const double before = offset_;
    offset_ = started_ ? offset_ + (wanted_ - offset_) * smoothing : wanted_;
    frame[1] += static_cast<float>(started_ ? offset_ - before : offset_);
    started_ = true;
  }
}

std::vector<uint8_t> plant_feet(const Skeleton& skeleton, MotionFrames& motion, double rate_hz,
                                const FootContactThresholds& thresholds) {
  const int64_t frames = motion.frame_count();
  if (find_feet(skeleton).empty() || frames < 2) return std::vector<uint8_t>(static_cast<size_t>(std::max<int64_t>(frames, 0)), 0);
  // One pass of forward kinematics: each pose about its root, which the
  // correction keeps, and on the root's path as given the feet's heights
  // and tracks.
  const FeetPoses poses = feet_poses(skeleton, motion);
  const FeetOnTheFloor on = feet_on_the_floor(poses, root_positions(motion));
  const auto contacts = planted_feet(on, frames, rate_hz, thresholds);
  const size_t foot_count = poses.feet.joints.size();
  // Each planted frame's root change is chosen so that the point each
  // planted foot stands on (its lowest joint) lands, on average, where it
  // was in the frame before, on the path as corrected so far.
  for (int64_t f = 1; f < frames; ++f) {
    const uint8_t planted = contacts[static_cast<size_t>(f)];
    if (planted == 0) continue;
    double slip_x = 0, slip_z = 0;
    int joints = 0;
    for (size_t k = 0; k < foot_count && k < 8; ++k) {
      if (!(planted & (1u << k))) continue;
      const size_t i = on.tracks.joint[static_cast<size_t>(f) * foot_count + k];
      const Vec3& now = poses.at(f, k, i);
      const Vec3& before = poses.at(f - 1, k, i);
      // The joint's world change is the root's change plus the pose's.
      slip_x += motion.frame(f)[0] + now[0] - before[0];
      slip_z += motion.frame(f)[2] + now[2] - before[2];
      ++joints;
    }
    motion.frame(f)[0] -= static_cast<float>(slip_x / joints);
    motion.frame(f)[2] -= static_cast<float>(slip_z / joints);
  }
  return contacts;
}

}  // namespace mm
