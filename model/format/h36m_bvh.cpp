#include "format/h36m_bvh.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "format/input_error.h"
#include "format/skeleton.h"

namespace mm {
namespace {

std::vector<bool> leaves(const Skeleton& skeleton) {
  std::vector<bool> leaf(skeleton.joints.size(), true);
  for (const auto& joint : skeleton.joints) {
    if (joint.parent >= 0) leaf[joint.parent] = false;
  }
  return leaf;
}

std::vector<BvhChannel> rotation_channels(const EulerOrder& order) {
  std::vector<BvhChannel> channels;
  for (int axis : order.axes) channels.push_back(static_cast<BvhChannel>(3 + axis));
  return channels;
}

std::string list(const std::vector<std::string>& names) {
  std::string out;
  const size_t shown = std::min<size_t>(names.size(), 8);
  for (size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > shown) out += " and " + std::to_string(names.size() - shown) + " more";
  return out;
}

// For each H3.6M joint, the BVH joint that carries its rotation, or -1 for
// a leaf that is an End Site (or a joint without rotation). Throws when the
// hierarchy is another.
std::vector<int> match_h36m(const BvhFile& file, const std::string& source) {
  const Skeleton h36m = Skeleton::h36m();
  const std::vector<bool> leaf = leaves(h36m);
  std::map<std::string, int> by_name;
  for (size_t j = 0; j < file.joints.size(); ++j) {
    if (!file.joints[j].end_site) by_name[file.joints[j].name] = static_cast<int>(j);
  }
  auto has_end_site = [&](int bvh_joint) {
    for (const auto& joint : file.joints) {
      if (joint.end_site && joint.parent == bvh_joint) return true;
    }
    return false;
  };
  const std::string prefix = source + ": not the H3.6M skeleton (" + h36m.name + "): ";

  std::vector<int> match(h36m.joints.size(), -1);
  std::vector<std::string> missing, unexpected, wrong_parent;
  std::map<std::string, bool> known;
  for (size_t j = 0; j < h36m.joints.size(); ++j) {
    const Joint& joint = h36m.joints[j];
    known[joint.name] = true;
    const auto found = by_name.find(joint.name);
    const std::string parent_name = joint.parent >= 0 ? h36m.joints[joint.parent].name : "";
    if (found == by_name.end()) {
      const auto parent = by_name.find(parent_name);
      if (leaf[j] && parent != by_name.end() && has_end_site(parent->second)) continue;  // an End Site
      missing.push_back(joint.name + (leaf[j] ? " (or an End Site under " + parent_name + ")" : ""));
      continue;
    }
    match[j] = found->second;
    const int bvh_parent = file.joints[found->second].parent;
    const std::string bvh_parent_name = bvh_parent >= 0 ? file.joints[bvh_parent].name : "";
    if (bvh_parent_name != parent_name) {
      wrong_parent.push_back(joint.name + "'s parent is " + (bvh_parent < 0 ? "none (it is the ROOT)" : bvh_parent_name) +
                             ", expected " + (joint.parent < 0 ? "none (the ROOT)" : parent_name));
    }
  }
  for (const auto& [name, index] : by_name) {
    if (!known.count(name)) unexpected.push_back(name);
  }
  if (missing.empty() && unexpected.empty() && wrong_parent.empty()) return match;
  std::string message = prefix + "it has " + std::to_string(file.named_joint_count()) + " joints and " +
                        std::to_string(file.joints.size() - file.named_joint_count()) +
                        " end sites, the H3.6M skeleton 25 joints and 7 end sites (or up to 32 joints)";
  if (!missing.empty()) message += "; missing joints: " + list(missing);
  if (!unexpected.empty()) message += "; unexpected joints: " + list(unexpected);
  if (!wrong_parent.empty()) message += "; a different parent: " + list(wrong_parent);
  throw InputError(message);
}

}  // namespace

BvhFile h36m_motion_to_bvh(const MotionFrames& motion, double rate_hz, const H36mBvhExportOptions& options) {
  if (motion.columns != kH36mColumns) {
    throw InputError("BVH export: a motion of " + std::to_string(motion.columns) + " columns, expected " +
                     std::to_string(kH36mColumns) + " (the H3.6M layout)");
  }
  if (motion.frame_count() < 1) throw InputError("BVH export: the motion has no frames");
  if (!std::isfinite(rate_hz) || rate_hz <= 0 || rate_hz > 1e5) {
    throw InputError("BVH export: rate " + std::to_string(rate_hz) + " Hz, expected a positive rate up to 1e5 Hz");
  }
  const Skeleton h36m = Skeleton::h36m();
  const std::vector<bool> leaf = leaves(h36m);
  BvhFile file;
  file.frame_time_s = 1.0 / rate_hz;
  for (size_t j = 0; j < h36m.joints.size(); ++j) {
    BvhJoint joint;
    joint.parent = h36m.joints[j].parent;
    joint.offset = h36m.joints[j].offset_mm;
    joint.end_site = leaf[j];
    if (!joint.end_site) {
      joint.name = h36m.joints[j].name;
      if (j == 0 || options.position_channels_on_every_joint) {
        joint.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
      }
      for (BvhChannel channel : rotation_channels(options.rotation_order)) joint.channels.push_back(channel);
    }
    file.joints.push_back(std::move(joint));
  }
  const int64_t frames = motion.frame_count();
  file.values.reserve(static_cast<size_t>(frames) * file.channel_count());
  Vec3 root{0, 0, 0};
  for (int64_t f = 0; f < frames; ++f) {
    const float* values = motion.frame(f);
    for (int c = 0; c < kH36mColumns; ++c) {
      if (!std::isfinite(values[c])) {
        throw InputError("BVH export: frame " + std::to_string(f) + " column " + std::to_string(c) + " is not finite");
      }
    }
    for (size_t j = 0; j < h36m.joints.size(); ++j) {
      if (leaf[j]) continue;
      if (j == 0) {
        for (int k = 0; k < 3; ++k) {
          root[k] += values[k];
          file.values.push_back(root[k]);
        }
      } else if (options.position_channels_on_every_joint) {
        file.values.insert(file.values.end(), {0.0, 0.0, 0.0});
      }
      const float* e = values + 3 + 3 * j;
      // Our R acts on row vectors; BVH's local matrix acts on columns: R^T.
      const Mat3 local = transpose(expmap_to_matrix({e[0], e[1], e[2]}));
      const Vec3 degrees = matrix_to_euler_degrees(options.rotation_order, local);
      file.values.insert(file.values.end(), degrees.begin(), degrees.end());
    }
  }
  return file;
}

std::string h36m_motion_to_bvh_text(const MotionFrames& motion, double rate_hz, const H36mBvhExportOptions& options) {
  return write_bvh_text(h36m_motion_to_bvh(motion, rate_hz, options));
}

MotionFrames h36m_motion_from_bvh(const BvhFile& file, const std::string& source_name) {
  const std::vector<int> match = match_h36m(file, source_name);
  const int64_t source_frames = file.frame_count();
  if (source_frames < 1) throw InputError(source_name + ": no frames");
  const double duration = static_cast<double>(source_frames - 1) * file.frame_time_s;
  // 1e-9 keeps k/25 that equals a frame's time up to rounding on that frame.
  const double last = std::floor(duration * kH36mBvhImportRate + 1e-9);
  if (last + 1 > static_cast<double>(kMaxH36mBvhImportFrames)) {
    throw InputError(source_name + ": " + std::to_string(source_frames) + " frames of " +
                     std::to_string(file.frame_time_s) + " s would be more than " +
                     std::to_string(kMaxH36mBvhImportFrames) + " frames at 25 Hz");
  }
  const int64_t frames = static_cast<int64_t>(last) + 1;
  const int channels = file.channel_count();
  const std::vector<int> first = file.first_channels();

  MotionFrames motion;
  motion.columns = kH36mColumns;
  motion.values.assign(static_cast<size_t>(frames) * kH36mColumns, 0.0f);
  Vec3 previous{0, 0, 0};
  for (int64_t k = 0; k < frames; ++k) {
    const double t = static_cast<double>(k) / kH36mBvhImportRate;
    int64_t source = static_cast<int64_t>(std::floor(t / file.frame_time_s + 0.5));
    if (source > source_frames - 1) source = source_frames - 1;
    const double* values = file.values.data() + source * channels;
    float* out = motion.frame(k);
    for (size_t j = 0; j < match.size(); ++j) {
      if (match[j] < 0) continue;
      const BvhJoint& joint = file.joints[match[j]];
      Mat3 local = identity_matrix();
      Vec3 position{0, 0, 0};
      for (size_t c = 0; c < joint.channels.size(); ++c) {
        const double value = values[first[match[j]] + c];
        const int axis = bvh_channel_axis(joint.channels[c]);
        if (bvh_channel_is_position(joint.channels[c])) {
          position[axis] = value;
        } else {
          local = multiply(local, axis_rotation(axis, value * 3.14159265358979323846 / 180.0));
        }
      }
      const Vec3 e = matrix_to_expmap(transpose(local));
      for (int c = 0; c < 3; ++c) out[3 + 3 * j + c] = static_cast<float>(e[c]);
      if (j == 0) {
        for (int c = 0; c < 3; ++c) {
          const double change = k == 0 ? 0.0 : position[c] - previous[c];
          if (std::fabs(change) > kMaxRootTranslationMm) {
            throw InputError(source_name + ": the root moves " + std::to_string(change) + " mm between 25 Hz frames " +
                             std::to_string(k - 1) + " and " + std::to_string(k) + ", more than " +
                             std::to_string(kMaxRootTranslationMm) + " mm");
          }
          out[c] = static_cast<float>(change);
        }
        previous = position;
      }
    }
  }
  return motion;
}

MotionFrames h36m_motion_from_bvh_text(const std::string& text, const std::string& source_name) {
  return h36m_motion_from_bvh(parse_bvh_text(text, source_name), source_name);
}

}  // namespace mm
