#include "format/node_animation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include "format/input_error.h"
#include "format/skeleton_bvh.h"

namespace mm {
namespace {

constexpr double kPi = 3.14159265358979323846;
// A translation that changes by less (metres, summed over the axes) over a
// whole animation is a bone's fixed offset sampled with float rounding.
constexpr double kStillMetres = 1e-6;
// Likewise a quaternion component (about 2e-6 rad): float rounding.
constexpr double kStillQuaternion = 1e-6;

Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 subtract(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 scaled(const Vec3& v, double s) { return {v[0] * s, v[1] * s, v[2] * s}; }

Mat3 diagonal(const Vec3& d) {
  Mat3 m{};
  for (int k = 0; k < 3; ++k) m[k][k] = d[k];
  return m;
}

// The rotation of a linear map that may carry a scale: its columns made
// orthonormal (Gram-Schmidt), enough for the uniform scales animation files
// put on armatures and scenes.
Mat3 rotation_part(const Mat3& m) {
  Vec3 c[3];
  for (int j = 0; j < 3; ++j) c[j] = {m[0][j], m[1][j], m[2][j]};
  auto dot = [](const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto normalised = [&](const Vec3& v) {
    const double n = std::sqrt(dot(v, v));
    return n > 0 ? scaled(v, 1.0 / n) : v;
  };
  c[0] = normalised(c[0]);
  c[1] = normalised(subtract(c[1], scaled(c[0], dot(c[0], c[1]))));
  c[2] = {c[0][1] * c[1][2] - c[0][2] * c[1][1], c[0][2] * c[1][0] - c[0][0] * c[1][2],
          c[0][0] * c[1][1] - c[0][1] * c[1][0]};
  Mat3 r{};
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) r[i][j] = c[j][i];
  }
  return r;
}

// A node name as a BVH word: no whitespace or braces (they end a token).
std::string bvh_word(const std::string& name) {
  std::string out = name;
  for (char& c : out) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == '{' || c == '}' || static_cast<unsigned char>(c) < 32) c = '_';
  }
  return out;
}

}  // namespace

Quaternion matrix_to_quaternion(const Mat3& m) {
  // Shepperd's method: the largest of w, x, y, z first, accurate everywhere.
  const double trace = m[0][0] + m[1][1] + m[2][2];
  Quaternion q;
  if (trace > m[0][0] && trace > m[1][1] && trace > m[2][2]) {
    const double s = std::sqrt(1.0 + trace) * 2;
    q = {(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2;
    q = {0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s};
  } else if (m[1][1] > m[2][2]) {
    const double s = std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2;
    q = {(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s};
  } else {
    const double s = std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2;
    q = {(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s};
  }
  if (q[3] < 0) {
    for (double& v : q) v = -v;
  }
  return q;
}

Mat3 quaternion_to_matrix(const Quaternion& in) {
  const double n = std::sqrt(in[0] * in[0] + in[1] * in[1] + in[2] * in[2] + in[3] * in[3]);
  if (!(n > 0) || !std::isfinite(n)) return identity_matrix();
  const double x = in[0] / n, y = in[1] / n, z = in[2] / n, w = in[3] / n;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
           {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
           {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}}};
}

NodeAnimation node_animation_from_bvh(const BvhFile& file, double millimetres_per_unit) {
  const double metres = millimetres_per_unit / 1000.0;
  // bvh_skeleton names End Sites as the rest of the library does.
  const Skeleton named = bvh_skeleton(file, "animation");
  NodeAnimation animation;
  animation.rate_hz = bvh_frame_rate(file);
  animation.frames = file.frame_count();
  animation.millimetres_per_unit = millimetres_per_unit;
  for (size_t j = 0; j < file.joints.size(); ++j) {
    const BvhJoint& joint = file.joints[j];
    AnimationNode node;
    node.name = named.joints[j].name;
    node.parent = joint.parent;
    node.rest_translation = scaled(joint.offset, metres);
    node.has_bvh_layout = true;
    node.end_site = joint.end_site;
    node.bvh_channels = joint.channels;
    for (BvhChannel channel : joint.channels) {
      (bvh_channel_is_position(channel) ? node.animated_translation : node.animated_rotation) = true;
    }
    animation.nodes.push_back(std::move(node));
  }
  const size_t nodes = file.joints.size();
  const int channels = file.channel_count();
  animation.translations.resize(static_cast<size_t>(animation.frames) * nodes);
  animation.rotations.resize(static_cast<size_t>(animation.frames) * nodes);
  for (int64_t f = 0; f < animation.frames; ++f) {
    const double* values = file.values.data() + f * channels;
    int next = 0;
    for (size_t j = 0; j < nodes; ++j) {
      const BvhJoint& joint = file.joints[j];
      Vec3 translation = joint.offset;
      Mat3 rotation = identity_matrix();
      for (BvhChannel channel : joint.channels) {
        const double value = values[next++];
        if (bvh_channel_is_position(channel)) {
          translation[bvh_channel_axis(channel)] += value;
        } else {
          rotation = multiply(rotation, axis_rotation(bvh_channel_axis(channel), value * kPi / 180.0));
        }
      }
      animation.translations[f * nodes + j] = scaled(translation, metres);
      animation.rotations[f * nodes + j] = matrix_to_quaternion(rotation);
    }
  }
  return animation;
}

BvhFile bvh_from_node_animation(const NodeAnimation& animation, double millimetres_per_unit,
                                const std::string& source_name) {
  const size_t nodes = animation.nodes.size();
  if (nodes == 0) throw InputError(source_name + ": no skeleton (no animated node tree)");
  if (nodes > static_cast<size_t>(kMaxBvhJoints)) {
    throw InputError(source_name + ": a skeleton of " + std::to_string(nodes) + " nodes, more than the " +
                     std::to_string(kMaxBvhJoints) + " a motion may have");
  }
  if (!std::isfinite(animation.rate_hz) || animation.rate_hz < 1.0 / kMaxBvhFrameTime ||
      animation.rate_hz > 1.0 / kMinBvhFrameTime) {
    throw InputError(source_name + ": a frame rate of " + std::to_string(animation.rate_hz) +
                     " Hz, expected 1 to 1000 Hz");
  }
  const double units_per_metre = 1000.0 / millimetres_per_unit;

  // The layout: the file's own where it recorded one for every node.
  const bool own_layout = std::all_of(animation.nodes.begin(), animation.nodes.end(),
                                      [](const AnimationNode& n) { return n.has_bvh_layout; });
  std::vector<bool> has_children(nodes, false);
  for (const auto& node : animation.nodes) {
    if (node.parent >= 0) has_children[node.parent] = true;
  }
  // Without a layout, a joint gets position channels where the file moves
  // it: the root, and any joint whose translation changes.
  std::vector<bool> moves(nodes, false);
  for (size_t j = 0; j < nodes && !own_layout; ++j) {
    for (int64_t f = 1; f < animation.frames && !moves[j]; ++f) {
      const Vec3 change = subtract(animation.translations[f * nodes + j], animation.translations[j]);
      moves[j] = std::abs(change[0]) + std::abs(change[1]) + std::abs(change[2]) > kStillMetres;
    }
  }
  BvhFile file;
  file.frame_time_s = 1.0 / animation.rate_hz;
  std::set<std::string> taken;
  for (size_t j = 0; j < nodes; ++j) {
    const AnimationNode& node = animation.nodes[j];
    BvhJoint joint;
    joint.parent = node.parent;
    if (own_layout) {
      joint.end_site = node.end_site;
      joint.channels = node.bvh_channels;
    } else {
      joint.end_site = j > 0 && !has_children[j] && !node.animated_rotation && !node.animated_translation;
      if (!joint.end_site) {
        if (j == 0 || moves[j]) joint.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
        for (BvhChannel c : {BvhChannel::kZrotation, BvhChannel::kYrotation, BvhChannel::kXrotation}) {
          joint.channels.push_back(c);
        }
      }
    }
    if (joint.end_site && has_children[j]) {
      throw InputError(source_name + ": node \"" + node.name + "\" is marked an End Site but has children");
    }
    if (!joint.end_site) {
      std::string name = bvh_word(node.name);
      if (name.empty()) name = "joint" + std::to_string(j);
      std::string unique = name;
      for (int k = 2; taken.count(unique); ++k) unique = name + "_" + std::to_string(k);
      taken.insert(unique);
      joint.name = unique;
    }
    file.joints.push_back(std::move(joint));
  }

  // World transforms of a pose: linear parts (rotation and scale) and positions.
  std::vector<Mat3> linear(nodes);
  std::vector<Vec3> position(nodes);
  auto pose = [&](const Vec3* translations, const Quaternion* rotations) {
    for (size_t j = 0; j < nodes; ++j) {
      const AnimationNode& node = animation.nodes[j];
      const Mat3 local = multiply(quaternion_to_matrix(rotations[j]), diagonal(node.rest_scale));
      const Mat3& parent_linear = node.parent < 0 ? animation.above_root_linear : linear[node.parent];
      const Vec3& parent_position = node.parent < 0 ? animation.above_root_translation : position[node.parent];
      linear[j] = multiply(parent_linear, local);
      position[j] = add(parent_position, multiply(parent_linear, translations[j]));
    }
  };
  std::vector<Vec3> rest_translations(nodes);
  std::vector<Quaternion> rest_rotations(nodes);
  for (size_t j = 0; j < nodes; ++j) {
    rest_translations[j] = animation.nodes[j].rest_translation;
    rest_rotations[j] = animation.nodes[j].rest_rotation;
  }
  pose(rest_translations.data(), rest_rotations.data());
  std::vector<Mat3> rest_rotation_inverse(nodes);
  for (size_t j = 0; j < nodes; ++j) {
    rest_rotation_inverse[j] = transpose(rotation_part(linear[j]));
    const Vec3 offset = animation.nodes[j].parent < 0 ? position[j] : subtract(position[j], position[animation.nodes[j].parent]);
    file.joints[j].offset = scaled(offset, units_per_metre);
  }

  std::vector<EulerOrder> orders(nodes);
  for (size_t j = 0; j < nodes; ++j) orders[j] = bvh_rotation_order(file.joints[j].channels);
  const int channels = file.channel_count();
  if (channels == 0) throw InputError(source_name + ": no animated joint");
  file.values.resize(static_cast<size_t>(animation.frames) * channels);
  std::vector<Mat3> bvh_world(nodes);
  for (int64_t f = 0; f < animation.frames; ++f) {
    pose(animation.translations.data() + f * nodes, animation.rotations.data() + f * nodes);
    double* values = file.values.data() + f * channels;
    const double* previous = f > 0 ? values - channels : nullptr;
    int next = 0;
    for (size_t j = 0; j < nodes; ++j) {
      const BvhJoint& joint = file.joints[j];
      // The joint's world rotation with its rest rotation taken out, so that
      // the world-axis offsets of the rest pose turn with it.
      bvh_world[j] = multiply(rotation_part(linear[j]), rest_rotation_inverse[j]);
      if (joint.channels.empty()) continue;
      const Mat3 parent_world = joint.parent < 0 ? identity_matrix() : bvh_world[joint.parent];
      const Vec3 parent_position = joint.parent < 0 ? Vec3{0, 0, 0} : position[joint.parent];
      const Mat3 local = multiply(transpose(parent_world), bvh_world[j]);
      const Vec3 moved = subtract(scaled(multiply(transpose(parent_world), subtract(position[j], parent_position)),
                                         units_per_metre),
                                  joint.offset);
      const Vec3 degrees = matrix_to_euler_degrees(orders[j], local);
      int rotation_index = 0;
      for (BvhChannel channel : joint.channels) {
        double value;
        if (bvh_channel_is_position(channel)) {
          value = moved[bvh_channel_axis(channel)];
        } else {
          value = degrees[rotation_index++];
          // The turn nearest the previous frame's angle: the same rotation,
          // and curves that animation tools interpolate without a spin.
          if (previous) value += 360.0 * std::round((previous[next] - value) / 360.0);
        }
        values[next++] = value;
      }
    }
  }
  return file;
}

namespace {

// The key at or before `t` in `times` (ascending), from `*at` on, and the
// fraction of the way to the next: sampling walks forward in time. A key
// within `snap` of `t` is taken as it is: files store times as 32-bit floats
// (2e-6 s off at 60 s), and interpolating that far between two frames of a
// fast movement would move a joint by a hundredth of a millimetre.
double segment(const std::vector<double>& times, double t, double snap, size_t* at) {
  while (*at + 1 < times.size() && times[*at + 1] <= t + snap) ++*at;
  if (*at + 1 >= times.size() || t <= times[*at] + snap) return 0;
  const double span = times[*at + 1] - times[*at];
  return span > 0 ? (t - times[*at]) / span : 0;
}

Quaternion slerp(Quaternion a, const Quaternion& b, double u) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0) {
    for (double& v : a) v = -v;
    dot = -dot;
  }
  double wa = 1 - u, wb = u;
  if (dot < 0.9999) {
    const double angle = std::acos(std::min(1.0, dot));
    wa = std::sin((1 - u) * angle) / std::sin(angle);
    wb = std::sin(u * angle) / std::sin(angle);
  }
  return {wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2], wa * a[3] + wb * b[3]};
}

void check_times(const std::vector<double>& times, size_t values, const std::string& what) {
  if (times.size() != values) {
    throw InputError(what + ": " + std::to_string(times.size()) + " key times for " + std::to_string(values) +
                     " values");
  }
  for (size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k]) || (k > 0 && times[k] < times[k - 1])) {
      throw InputError(what + ": key " + std::to_string(k) + "'s time " + std::to_string(times[k]) +
                       " s, expected finite times that never decrease");
    }
  }
}

}  // namespace

void sample_node_keyframes(NodeAnimation& animation, const std::vector<NodeKeyframes>& keys, size_t input_bytes,
                           const std::string& source_name, const BvhFrameLimit& limit) {
  const size_t nodes = animation.nodes.size();
  double start = 0, end = 0;
  bool any = false;
  std::vector<std::vector<double>> series;
  for (size_t j = 0; j < nodes; ++j) {
    const NodeKeyframes& k = keys[j];
    const std::string what = source_name + ": node \"" + animation.nodes[j].name + "\"";
    check_times(k.translation_times, k.translations.size(), what + "'s translation");
    check_times(k.rotation_times, k.rotations.size(), what + "'s rotation");
    for (const Vec3& v : k.translations) {
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
        throw InputError(what + ": a translation key that is not finite");
      }
    }
    for (const Quaternion& q : k.rotations) {
      if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]) || !std::isfinite(q[3])) {
        throw InputError(what + ": a rotation key that is not finite");
      }
    }
    for (const auto* times : {&k.translation_times, &k.rotation_times}) {
      if (times->empty()) continue;
      start = any ? std::min(start, times->front()) : times->front();
      end = any ? std::max(end, times->back()) : times->back();
      any = true;
      series.push_back(*times);
    }
    animation.nodes[j].animated_translation = !k.translations.empty();
    animation.nodes[j].animated_rotation = !k.rotations.empty();
  }
  if (!any) throw InputError(source_name + ": the animation moves no node of the skeleton");
  double rate = keyframe_rate(series);
  if (rate == 0) rate = kBvhImportRate;  // a single pose
  const int64_t frames = node_animation_frame_count(end - start, rate, source_name, limit);
  const double budget = std::max(4e6, input_bytes / 4.0);
  if (static_cast<double>(frames) * nodes > budget) {
    throw InputError(source_name + ": " + std::to_string(frames) + " frames of " + std::to_string(nodes) +
                     " nodes from a file of " + std::to_string(input_bytes) +
                     " bytes, more than such a file may hold (frames x nodes at most a quarter of its bytes, or 4 million)");
  }
  animation.rate_hz = rate;
  animation.frames = frames;
  animation.translations.resize(static_cast<size_t>(frames) * nodes);
  animation.rotations.resize(static_cast<size_t>(frames) * nodes);
  std::vector<size_t> translation_at(nodes, 0), rotation_at(nodes, 0);
  for (int64_t f = 0; f < frames; ++f) {
    const double t = start + f / rate;
    // A thousandth of a frame, and the float rounding of times near t.
    const double snap = 1e-3 / rate + 4 * std::abs(t) * 1.2e-7;
    for (size_t j = 0; j < nodes; ++j) {
      const NodeKeyframes& k = keys[j];
      Vec3 translation = animation.nodes[j].rest_translation;
      if (!k.translations.empty()) {
        const double u = segment(k.translation_times, t, snap, &translation_at[j]);
        const Vec3& a = k.translations[translation_at[j]];
        if (u == 0 || k.translation_step) {
          translation = a;
        } else {
          const Vec3& b = k.translations[translation_at[j] + 1];
          for (int c = 0; c < 3; ++c) translation[c] = a[c] + u * (b[c] - a[c]);
        }
      }
      Quaternion rotation = animation.nodes[j].rest_rotation;
      if (!k.rotations.empty()) {
        const double u = segment(k.rotation_times, t, snap, &rotation_at[j]);
        const Quaternion& a = k.rotations[rotation_at[j]];
        rotation = u == 0 || k.rotation_step ? a : slerp(a, k.rotations[rotation_at[j] + 1], u);
      }
      animation.translations[f * nodes + j] = translation;
      animation.rotations[f * nodes + j] = rotation;
    }
  }
}

void drop_still_roots(NodeAnimation& animation) {
  while (animation.nodes.size() > 1 && !animation.nodes[0].has_bvh_layout) {
    const size_t nodes = animation.nodes.size();
    const size_t children = std::count_if(animation.nodes.begin(), animation.nodes.end(),
                                          [](const AnimationNode& n) { return n.parent == 0; });
    if (children != 1) return;
    for (int64_t f = 1; f < animation.frames; ++f) {
      const Vec3 move = subtract(animation.translations[f * nodes], animation.translations[0]);
      const Quaternion& q = animation.rotations[f * nodes];
      const Quaternion& q0 = animation.rotations[0];
      double same = 0, opposite = 0;  // q and -q are one rotation
      for (int k = 0; k < 4; ++k) {
        same = std::max(same, std::abs(q[k] - q0[k]));
        opposite = std::max(opposite, std::abs(q[k] + q0[k]));
      }
      if (std::abs(move[0]) + std::abs(move[1]) + std::abs(move[2]) > kStillMetres ||
          std::min(same, opposite) > kStillQuaternion) {
        return;
      }
    }
    // Fold its pose into the transform above the root.
    const AnimationNode& root = animation.nodes[0];
    const Mat3 local = multiply(quaternion_to_matrix(animation.rotations[0]), diagonal(root.rest_scale));
    animation.above_root_translation =
        add(animation.above_root_translation, multiply(animation.above_root_linear, animation.translations[0]));
    animation.above_root_linear = multiply(animation.above_root_linear, local);
    animation.nodes.erase(animation.nodes.begin());
    for (auto& node : animation.nodes) --node.parent;  // the new root's 0 becomes -1
    std::vector<Vec3> translations;
    std::vector<Quaternion> rotations;
    translations.reserve(static_cast<size_t>(animation.frames) * (nodes - 1));
    rotations.reserve(static_cast<size_t>(animation.frames) * (nodes - 1));
    for (int64_t f = 0; f < animation.frames; ++f) {
      translations.insert(translations.end(), animation.translations.begin() + f * nodes + 1,
                          animation.translations.begin() + (f + 1) * nodes);
      rotations.insert(rotations.end(), animation.rotations.begin() + f * nodes + 1,
                       animation.rotations.begin() + (f + 1) * nodes);
    }
    animation.translations.swap(translations);
    animation.rotations.swap(rotations);
  }
}

double keyframe_rate(const std::vector<std::vector<double>>& key_times) {
  const std::vector<double>* longest = nullptr;
  for (const auto& times : key_times) {
    if (times.size() >= 2 && (!longest || times.size() > longest->size())) longest = &times;
  }
  if (!longest) return 0;
  const double span = longest->back() - longest->front();
  if (!(span > 0)) return 0;
  return std::round((longest->size() - 1) / span * 1000.0) / 1000.0;
}

int64_t node_animation_frame_count(double duration_s, double rate_hz, const std::string& source_name,
                                   const BvhFrameLimit& limit) {
  if (!std::isfinite(rate_hz) || rate_hz < 1.0 / kMaxBvhFrameTime || rate_hz > 1.0 / kMinBvhFrameTime) {
    throw InputError(source_name + ": keyframes at " + std::to_string(rate_hz) + " Hz, expected 1 to 1000 Hz");
  }
  if (!std::isfinite(duration_s) || duration_s < 0 || duration_s * rate_hz > 4e9) {
    throw InputError(source_name + ": an animation of " + std::to_string(duration_s) + " s, more than " +
                     limit.name + " allows");
  }
  const int64_t frames = static_cast<int64_t>(std::llround(duration_s * rate_hz)) + 1;
  const int64_t at_25_hz = bvh_imported_frame_count(frames, 1.0 / rate_hz);
  if (at_25_hz > limit.frames) {
    throw InputError(source_name + ": " + std::to_string(frames) + " frames at " + std::to_string(rate_hz) +
                     " Hz make " + std::to_string(at_25_hz) + " frames at 25 Hz, more than the " +
                     std::to_string(limit.frames) + " of " + limit.name);
  }
  return frames;
}

}  // namespace mm
