#include "format/motion_mirror.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include "format/input_error.h"

namespace mm {

namespace {

// The name of `name`'s twin on the other side, or none for a joint named
// as no side.
std::optional<std::string> twin_name(const std::string& name) {
  static const std::pair<const char*, const char*> kWords[] = {{"Left", "Right"}, {"left", "right"}};
  for (const auto& [a, b] : kWords) {
    for (const auto& [from, to] : {std::pair{a, b}, std::pair{b, a}}) {
      const size_t at = name.find(from);
      if (at != std::string::npos) return name.substr(0, at) + to + name.substr(at + std::string(from).size());
    }
  }
  if (name.size() >= 2 && std::isupper(static_cast<unsigned char>(name[1]))) {
    static const std::map<char, char> kLetters = {{'l', 'r'}, {'r', 'l'}, {'L', 'R'}, {'R', 'L'}};
    const auto it = kLetters.find(name[0]);
    if (it != kLetters.end()) return std::string(1, it->second) + name.substr(1);
  }
  return std::nullopt;
}

// How far a rest pose may be from its mirror image: a mocap rig's sides
// are measured, not made equal (the CMU dance rig's head is 2.4 mm off its
// middle, its eyes 41.5 and 36.6 mm from it).
constexpr double kToleranceMm = 5.0, kToleranceShare = 0.05;

std::string decimal(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

}  // namespace

MotionMirror motion_mirror(const Skeleton& skeleton) {
  const int joints = skeleton.joint_count();
  std::map<std::string, int> by_name;
  for (int j = 0; j < joints; ++j) by_name[skeleton.joints[static_cast<size_t>(j)].name] = j;
  std::vector<int> twin(static_cast<size_t>(joints));
  int paired = 0;
  for (int j = 0; j < joints; ++j) {
    const std::string& name = skeleton.joints[static_cast<size_t>(j)].name;
    const auto other = twin_name(name);
    twin[static_cast<size_t>(j)] = j;
    if (!other) continue;
    const auto it = by_name.find(*other);
    if (it == by_name.end()) {
      throw InputError("skeleton " + skeleton.name + ": joint " + name + " is named as a side but has no twin " +
                       *other + ", expected a pair of joints for a mirror image");
    }
    twin[static_cast<size_t>(j)] = it->second;
    ++paired;
  }
  if (paired == 0) {
    throw InputError("skeleton " + skeleton.name +
                     ": no joint is named as a side (Left/Right, left/right, or l/r before a capital), "
                     "expected left and right joints for a mirror image");
  }
  // The lateral axis: where twins' offsets differ most.
  MotionMirror mirror;
  double spread[3] = {0, 0, 0};
  for (int j = 0; j < joints; ++j) {
    const auto& a = skeleton.joints[static_cast<size_t>(j)].offset_mm;
    const auto& b = skeleton.joints[static_cast<size_t>(twin[static_cast<size_t>(j)])].offset_mm;
    for (int axis = 0; axis < 3; ++axis) spread[axis] += std::fabs(a[static_cast<size_t>(axis)] - b[static_cast<size_t>(axis)]);
  }
  for (int axis = 1; axis < 3; ++axis) {
    if (spread[axis] > spread[mirror.lateral_axis]) mirror.lateral_axis = axis;
  }
  // Its rest pose must be its own mirror image, and the twins' parents
  // twins; the offsets of end points (joints no bone hangs from) may
  // differ: H3.6M's wrist end sites are 100.0 mm from the hand on the left
  // and 137.5 on the right.
  std::vector<bool> bears_bone(static_cast<size_t>(joints), false);
  for (int j = joints - 1; j > 0; --j) {  // parents precede children
    const Joint& joint = skeleton.joints[static_cast<size_t>(j)];
    const bool bone = joint.offset_mm[0] != 0 || joint.offset_mm[1] != 0 || joint.offset_mm[2] != 0;
    if (bone || bears_bone[static_cast<size_t>(j)]) bears_bone[static_cast<size_t>(joint.parent)] = true;
  }
  for (int j = 0; j < joints; ++j) {
    const Joint& joint = skeleton.joints[static_cast<size_t>(j)];
    const Joint& other = skeleton.joints[static_cast<size_t>(twin[static_cast<size_t>(j)])];
    const int parent_twin = joint.parent < 0 ? -1 : twin[static_cast<size_t>(joint.parent)];
    if (other.parent != parent_twin) {
      throw InputError("skeleton " + skeleton.name + ": joint " + joint.name + "'s twin " + other.name +
                       " hangs from another joint than its parent's twin, expected a mirror image");
    }
    double length = 0, off = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double reflected = (axis == mirror.lateral_axis ? -1 : 1) * other.offset_mm[static_cast<size_t>(axis)];
      length += joint.offset_mm[static_cast<size_t>(axis)] * joint.offset_mm[static_cast<size_t>(axis)];
      off += (joint.offset_mm[static_cast<size_t>(axis)] - reflected) * (joint.offset_mm[static_cast<size_t>(axis)] - reflected);
    }
    if (bears_bone[static_cast<size_t>(j)] && std::sqrt(off) > kToleranceMm + kToleranceShare * std::sqrt(length)) {
      throw InputError("skeleton " + skeleton.name + ": joint " + joint.name + "'s offset is " +
                       decimal(std::sqrt(off)) + " mm from the mirror image of " + other.name +
                       "'s, expected a rest pose that is its own mirror image (within 5 mm and 5% of the bone)");
    }
  }
  const int columns = 3 + 3 * joints;
  mirror.source_column.resize(static_cast<size_t>(columns));
  mirror.sign.resize(static_cast<size_t>(columns));
  for (int axis = 0; axis < 3; ++axis) {
    mirror.source_column[static_cast<size_t>(axis)] = axis;
    mirror.sign[static_cast<size_t>(axis)] = axis == mirror.lateral_axis ? -1.0f : 1.0f;
  }
  for (int j = 0; j < joints; ++j) {
    for (int axis = 0; axis < 3; ++axis) {
      const auto column = static_cast<size_t>(3 + 3 * j + axis);
      mirror.source_column[column] = 3 + 3 * twin[static_cast<size_t>(j)] + axis;
      // A rotation vector is an axial vector: under a reflection its
      // component along the mirror's normal stays, the others turn.
      mirror.sign[column] = axis == mirror.lateral_axis ? 1.0f : -1.0f;
    }
  }
  return mirror;
}

MotionFrames mirrored(const MotionMirror& mirror, const MotionFrames& motion) {
  const int columns = static_cast<int>(mirror.source_column.size());
  if (motion.columns != columns) {
    throw std::invalid_argument("mirrored: a motion of " + std::to_string(motion.columns) +
                                " columns, expected the skeleton's " + std::to_string(columns));
  }
  MotionFrames out = motion;
  for (int64_t f = 0; f < motion.frame_count(); ++f) {
    const float* in = motion.frame(f);
    float* row = out.frame(f);
    for (int c = 0; c < columns; ++c) {
      row[c] = mirror.sign[static_cast<size_t>(c)] * in[mirror.source_column[static_cast<size_t>(c)]];
    }
  }
  return out;
}

NormalizedMirror normalized_mirror(const MotionMirror& mirror, const PoseNormalization& normalization) {
  if (normalization.input_columns() != static_cast<int>(mirror.source_column.size())) {
    throw InputError("normalization: " + std::to_string(normalization.input_columns()) +
                     " input columns, expected the skeleton's " + std::to_string(mirror.source_column.size()));
  }
  std::map<int, int> dim_of;
  for (int d = 0; d < normalization.dims(); ++d) dim_of[normalization.kept_columns[static_cast<size_t>(d)]] = d;
  NormalizedMirror out;
  for (int d = 0; d < normalization.dims(); ++d) {
    const int column = normalization.kept_columns[static_cast<size_t>(d)];
    const int source = mirror.source_column[static_cast<size_t>(column)];
    const auto it = dim_of.find(source);
    if (it == dim_of.end()) {
      throw InputError("normalization: column " + std::to_string(column) + " is kept but its mirror's column " +
                       std::to_string(source) + " is not, expected the kept columns to be their own mirror image");
    }
    // x' = (s (x_src std_src + mean_src) - mean) / std
    const double s = mirror.sign[static_cast<size_t>(column)];
    const double std_src = normalization.stddev[static_cast<size_t>(source)];
    const double std_own = normalization.stddev[static_cast<size_t>(column)];
    out.source_dim.push_back(it->second);
    out.scale.push_back(static_cast<float>(s * std_src / std_own));
    out.shift.push_back(static_cast<float>(
        (s * normalization.mean[static_cast<size_t>(source)] - normalization.mean[static_cast<size_t>(column)]) / std_own));
  }
  return out;
}

}  // namespace mm
