#include "format/root_path.h"

#include <cmath>
#include <vector>

#include "format/foot_contacts.h"

namespace mm {
namespace {

Vec3 scaled(const Vec3& v, double s) { return {v[0] * s, v[1] * s, v[2] * s}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 minus(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 normalized(const Vec3& v) {
  const double n = std::sqrt(dot(v, v));
  return n > 0 ? scaled(v, 1 / n) : Vec3{0, 1, 0};
}

// The principal direction of a symmetric 3x3 matrix (power iteration; the
// matrices here are covariances, positive semi-definite).
Vec3 principal_direction(const Mat3& m) {
  Vec3 v{1, 0.5, 0.25};
  for (int i = 0; i < 100; ++i) v = normalized(multiply(m, v));
  return v;
}

// The row-vector rotation that takes unit `from` to +y (about their common
// perpendicular), so that v R has the component along `from` in y.
Mat3 rotation_to_up(const Vec3& from) {
  const Vec3 up{0, 1, 0};
  const Vec3 axis = cross(from, up);
  const double sine = std::sqrt(dot(axis, axis)), cosine = dot(from, up);
  if (sine < 1e-12) return identity_matrix();
  const double angle = std::atan2(sine, cosine);
  // expmap_to_matrix gives the column-vector rotation by +angle about the
  // axis; applied to row vectors that is its transpose.
  return transpose(expmap_to_matrix(scaled(normalized(axis), angle)));
}

// `v` turned by `radians` about +y (column vectors: x towards -z).
Vec3 turned_about_up(const Vec3& v, double radians) {
  const double c = std::cos(radians), s = std::sin(radians);
  return {c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]};
}

}  // namespace

TrajectoryFrame trajectory_frame_of(const Skeleton& skeleton) {
  return skeleton.bvh ? TrajectoryFrame::kHeadingMoves : TrajectoryFrame::kRootChanges;
}

double heading_radians(const float* orientation) {
  // The row-vector matrix R is the column-vector M = R^T; the turn about y
  // closest to M in its x-z block has angle atan2(M02 - M20, M00 + M22).
  const Mat3 r = expmap_to_matrix({orientation[0], orientation[1], orientation[2]});
  return std::atan2(r[2][0] - r[0][2], r[0][0] + r[2][2]);
}

void heading_moves_from_world(MotionFrames& motion) {
  double before = 0;
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    float* frame = motion.frame(f);
    const double heading = heading_radians(frame + 3);
    const Vec3 local = turned_about_up({frame[0], frame[1], frame[2]}, -(f == 0 ? heading : before));
    for (int a = 0; a < 3; ++a) frame[a] = static_cast<float>(local[static_cast<size_t>(a)]);
    before = heading;
  }
}

void model_root_from_world(const Skeleton& skeleton, MotionFrames& motion, double rotation_steps) {
  if (trajectory_frame_of(skeleton) == TrajectoryFrame::kRootChanges) root_changes_from_world(motion, rotation_steps);
}

RootPathIntegrator::RootPathIntegrator(double rotation_steps, TrajectoryFrame frame)
    : rotation_steps_(rotation_steps), frame_(frame), orientation_(identity_matrix()) {}

void RootPathIntegrator::integrate(MotionFrames& motion) {
  if (frame_ == TrajectoryFrame::kHeadingMoves) {
    for (int64_t f = 0; f < motion.frame_count(); ++f) {
      float* frame = motion.frame(f);
      const Vec3 world = started_ ? turned_about_up({frame[0], frame[1], frame[2]}, heading_) : Vec3{0, 0, 0};
      for (int a = 0; a < 3; ++a) frame[a] = static_cast<float>(world[static_cast<size_t>(a)]);
      heading_ = heading_radians(frame + 3);
      started_ = true;
    }
    return;
  }
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    float* frame = motion.frame(f);
    const Vec3 move{frame[0], frame[1], frame[2]};
    const Vec3 change{frame[3], frame[4], frame[5]};
    const Mat3 before = orientation_;
    orientation_ = multiply(expmap_to_matrix(scaled(change, rotation_steps_)), started_ ? before : identity_matrix());
    const Vec3 world_move = started_ ? multiply(move, before) : Vec3{0, 0, 0};
    started_ = true;
    const Vec3 orientation = matrix_to_expmap(orientation_);
    for (int a = 0; a < 3; ++a) {
      frame[a] = static_cast<float>(world_move[static_cast<size_t>(a)]);
      frame[3 + a] = static_cast<float>(orientation[static_cast<size_t>(a)]);
    }
  }
}

void root_changes_from_world(MotionFrames& motion, double rotation_steps) {
  Mat3 before = identity_matrix();
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    float* frame = motion.frame(f);
    const Mat3 orientation = expmap_to_matrix({frame[3], frame[4], frame[5]});
    // R_f = D^steps R_(f-1) and a world move m = d R_(f-1), for row vectors.
    const Vec3 move = f == 0 ? Vec3{0, 0, 0} : multiply(Vec3{frame[0], frame[1], frame[2]}, transpose(before));
    const Vec3 change = scaled(matrix_to_expmap(multiply(orientation, transpose(before))), 1.0 / rotation_steps);
    for (int a = 0; a < 3; ++a) {
      frame[a] = static_cast<float>(move[static_cast<size_t>(a)]);
      frame[3 + a] = static_cast<float>(change[static_cast<size_t>(a)]);
    }
    before = orientation;
  }
}

FeetPoses integrate_level_root_path(const Skeleton& skeleton, MotionFrames& motion, double rotation_steps) {
  const int64_t frames = motion.frame_count();
  if (frames < 1) return FeetPoses{};
  RootPathIntegrator integrator(rotation_steps);
  integrator.integrate(motion);

  // The pelvis's mean up axis, and the root path's spread.
  Vec3 up{0, 0, 0}, position{0, 0, 0}, mean{0, 0, 0};
  std::vector<Vec3> path;
  for (int64_t f = 0; f < frames; ++f) {
    const float* frame = motion.frame(f);
    for (int a = 0; a < 3; ++a) position[static_cast<size_t>(a)] += frame[a];
    path.push_back(position);
    mean = {mean[0] + position[0] / frames, mean[1] + position[1] / frames, mean[2] + position[2] / frames};
    const Mat3 orientation = expmap_to_matrix({frame[3], frame[4], frame[5]});
    const Vec3 pelvis_up = multiply(Vec3{0, 1, 0}, orientation);
    up = {up[0] + pelvis_up[0], up[1] + pelvis_up[1], up[2] + pelvis_up[2]};
  }
  up = normalized(up);
  Mat3 spread{};
  for (const Vec3& p : path) {
    const Vec3 d = minus(p, mean);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) spread[static_cast<size_t>(i)][static_cast<size_t>(j)] += d[static_cast<size_t>(i)] * d[static_cast<size_t>(j)] / frames;
    }
  }
  // The path's directions of travel longer than 10 cm (rms) lie on the
  // floor: up is made perpendicular to them.
  for (int k = 0; k < 2; ++k) {
    const Vec3 direction = principal_direction(spread);
    const double variance = dot(direction, multiply(spread, direction));
    if (variance < 100.0 * 100.0) break;
    up = normalized(minus(up, scaled(direction, dot(up, direction))));
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        spread[static_cast<size_t>(i)][static_cast<size_t>(j)] -= variance * direction[static_cast<size_t>(i)] * direction[static_cast<size_t>(j)];
      }
    }
  }
  const Mat3 level = rotation_to_up(up);
  for (int64_t f = 0; f < frames; ++f) {
    float* frame = motion.frame(f);
    const Vec3 move = multiply(Vec3{frame[0], frame[1], frame[2]}, level);
    const Vec3 orientation = matrix_to_expmap(multiply(expmap_to_matrix({frame[3], frame[4], frame[5]}), level));
    for (int a = 0; a < 3; ++a) {
      frame[a] = static_cast<float>(move[static_cast<size_t>(a)]);
      frame[3 + a] = static_cast<float>(orientation[static_cast<size_t>(a)]);
    }
  }
  FeetPoses poses = feet_poses(skeleton, motion);
  motion.frame(0)[1] -= static_cast<float>(floor_height(poses, motion));
  return poses;
}

}  // namespace mm
