#include "format/skeleton_bvh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "format/input_error.h"
#include "format/motion_text.h"

namespace mm {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<bool> leaves(const Skeleton& skeleton) {
  std::vector<bool> leaf(skeleton.joints.size(), true);
  for (const auto& joint : skeleton.joints) {
    if (joint.parent >= 0) leaf[joint.parent] = false;
  }
  return leaf;
}

std::string list(const std::vector<std::string>& names) {
  std::string out;
  const size_t shown = std::min<size_t>(names.size(), 8);
  for (size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > shown) out += " and " + std::to_string(names.size() - shown) + " more";
  return out;
}

// How messages name the skeleton: H3.6M's by its familiar name.
std::string skeleton_label(const Skeleton& skeleton) {
  if (skeleton.name == Skeleton::h36m().name) return "the H3.6M skeleton (" + skeleton.name + ")";
  return "the skeleton \"" + skeleton.name + "\"";
}

std::vector<BvhChannel> parsed_channels(const std::vector<std::string>& names) {
  std::vector<BvhChannel> channels;
  for (const std::string& name : names) {
    BvhChannel channel;
    if (!parse_bvh_channel(name, &channel)) throw InputError("BVH layout: channel \"" + name + "\" is unknown");
    channels.push_back(channel);
  }
  return channels;
}

}  // namespace

EulerOrder bvh_rotation_order(const std::vector<BvhChannel>& channels, int* rotation_count) {
  std::vector<int> axes;
  for (BvhChannel channel : channels) {
    if (!bvh_channel_is_position(channel)) axes.push_back(bvh_channel_axis(channel));
  }
  if (rotation_count != nullptr) *rotation_count = static_cast<int>(axes.size());
  for (int axis = 0; axis < 3; ++axis) {
    if (std::find(axes.begin(), axes.end(), axis) == axes.end()) axes.push_back(axis);
  }
  EulerOrder order;
  for (int k = 0; k < 3; ++k) order.axes[k] = axes[k];
  return order;
}

int skeleton_motion_columns(const Skeleton& skeleton) { return kRootTranslationValues + 3 * skeleton.joint_count(); }

BvhLayout default_bvh_layout(const Skeleton& skeleton, const EulerOrder& rotation_order,
                             bool position_channels_on_every_joint) {
  const std::vector<bool> leaf = leaves(skeleton);
  BvhLayout layout;
  layout.millimetres_per_unit = 1.0;
  for (size_t j = 0; j < skeleton.joints.size(); ++j) {
    // A single-joint skeleton keeps its root as a joint.
    const bool end_site = leaf[j] && j > 0;
    std::vector<std::string> channels;
    if (!end_site) {
      if (j == 0 || position_channels_on_every_joint) channels = {"Xposition", "Yposition", "Zposition"};
      for (int axis : rotation_order.axes) channels.push_back(bvh_channel_name(static_cast<BvhChannel>(3 + axis)));
    }
    layout.channels.push_back(std::move(channels));
    layout.end_site.push_back(end_site);
  }
  return layout;
}

BvhLayout bvh_layout_of(const Skeleton& skeleton) { return skeleton.bvh ? *skeleton.bvh : default_bvh_layout(skeleton); }

BvhFile skeleton_motion_to_bvh(const Skeleton& skeleton, const BvhLayout& layout, const MotionFrames& motion,
                               double rate_hz) {
  const int columns = skeleton_motion_columns(skeleton);
  if (motion.columns != columns) {
    throw InputError("BVH export: a motion of " + std::to_string(motion.columns) + " columns, expected " +
                     std::to_string(columns) + " (3 + 3 x " + std::to_string(skeleton.joint_count()) + " joints of " +
                     skeleton_label(skeleton) + ")");
  }
  if (layout.channels.size() != skeleton.joints.size() || layout.end_site.size() != skeleton.joints.size()) {
    throw InputError("BVH export: a BVH layout of " + std::to_string(layout.channels.size()) + " joints for " +
                     skeleton_label(skeleton) + " of " + std::to_string(skeleton.joint_count()));
  }
  if (motion.frame_count() < 1) throw InputError("BVH export: the motion has no frames");
  // The rates whose frame time a BVH reader takes (bvh_file.h).
  if (!std::isfinite(rate_hz) || rate_hz < 1.0 / kMaxBvhFrameTime || rate_hz > 1.0 / kMinBvhFrameTime) {
    throw InputError("BVH export: rate " + std::to_string(rate_hz) + " Hz, expected 1 to 1000 Hz");
  }
  const double unit = layout.millimetres_per_unit;
  BvhFile file;
  file.frame_time_s = 1.0 / rate_hz;
  std::vector<EulerOrder> orders(skeleton.joints.size());
  std::vector<int> rotation_counts(skeleton.joints.size());
  for (size_t j = 0; j < skeleton.joints.size(); ++j) {
    BvhJoint joint;
    joint.parent = skeleton.joints[j].parent;
    for (int k = 0; k < 3; ++k) joint.offset[k] = skeleton.joints[j].offset_mm[k] / unit;
    joint.end_site = layout.end_site[j];
    if (!joint.end_site) {
      joint.name = skeleton.joints[j].name;
      joint.channels = parsed_channels(layout.channels[j]);
    }
    orders[j] = bvh_rotation_order(joint.channels, &rotation_counts[j]);
    file.joints.push_back(std::move(joint));
  }
  const int64_t frames = motion.frame_count();
  file.values.reserve(static_cast<size_t>(frames) * file.channel_count());
  Vec3 root{0, 0, 0};
  for (int64_t f = 0; f < frames; ++f) {
    const float* values = motion.frame(f);
    for (int c = 0; c < columns; ++c) {
      if (!std::isfinite(values[c])) {
        throw InputError("BVH export: frame " + std::to_string(f) + " column " + std::to_string(c) + " is not finite");
      }
    }
    for (int k = 0; k < 3; ++k) root[k] += values[k];
    for (size_t j = 0; j < skeleton.joints.size(); ++j) {
      const BvhJoint& joint = file.joints[j];
      if (joint.channels.empty()) continue;
      const float* e = values + 3 + 3 * j;
      // Our R acts on row vectors; BVH's local matrix acts on columns: R^T.
      const Mat3 local = transpose(expmap_to_matrix({e[0], e[1], e[2]}));
      const Vec3 degrees = matrix_to_euler_degrees(orders[j], local);
      int next_rotation = 0;
      for (BvhChannel channel : joint.channels) {
        if (bvh_channel_is_position(channel)) {
          file.values.push_back(j == 0 ? root[bvh_channel_axis(channel)] / unit : 0.0);
        } else {
          file.values.push_back(degrees[next_rotation++]);
        }
      }
    }
  }
  return file;
}

std::vector<int> match_bvh_to_skeleton(const Skeleton& skeleton, const BvhFile& file, const std::string& source_name) {
  const std::vector<bool> leaf = leaves(skeleton);
  std::map<std::string, int> by_name;
  for (size_t j = 0; j < file.joints.size(); ++j) {
    if (!file.joints[j].end_site) by_name[file.joints[j].name] = static_cast<int>(j);
  }
  // A leaf of the skeleton may be an End Site in the file, or absent where
  // its parent is a leaf there in a file without any End Site: animation
  // tools drop them all (Blender's BVH import makes them bone tails, which
  // its glTF and FBX exports leave out), and a leaf carries no motion. A
  // file that has End Sites but not this one is another hierarchy.
  std::set<int> parents_of_end_sites;
  std::vector<bool> file_leaf(file.joints.size(), true);
  for (const auto& joint : file.joints) {
    if (joint.end_site) parents_of_end_sites.insert(joint.parent);
    if (joint.parent >= 0) file_leaf[joint.parent] = false;
  }

  std::vector<int> match(skeleton.joints.size(), -1);
  std::vector<std::string> missing, unexpected, wrong_parent;
  std::set<std::string> known;
  for (size_t j = 0; j < skeleton.joints.size(); ++j) {
    const Joint& joint = skeleton.joints[j];
    known.insert(joint.name);
    const auto found = by_name.find(joint.name);
    const std::string parent_name = joint.parent >= 0 ? skeleton.joints[joint.parent].name : "";
    if (found == by_name.end()) {
      const auto parent = by_name.find(parent_name);
      if (leaf[j] && parent != by_name.end() &&
          (parents_of_end_sites.count(parent->second) || (parents_of_end_sites.empty() && file_leaf[parent->second]))) {
        continue;  // an End Site, or none
      }
      missing.push_back(joint.name + (leaf[j] && j > 0 ? " (or an End Site under " + parent_name + ")" : ""));
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

  const BvhLayout layout = bvh_layout_of(skeleton);
  const int end_sites = static_cast<int>(std::count(layout.end_site.begin(), layout.end_site.end(), true));
  const std::string label = skeleton_label(skeleton);
  std::string message = source_name + ": not " + label + ": it has " + std::to_string(file.named_joint_count()) +
                        " joints and " + std::to_string(file.joints.size() - file.named_joint_count()) +
                        " end sites, " + label + " " + std::to_string(skeleton.joint_count() - end_sites) +
                        " joints and " + std::to_string(end_sites) + " end sites (or up to " +
                        std::to_string(skeleton.joint_count()) + " joints)";
  if (!missing.empty()) message += "; missing joints: " + list(missing);
  if (!unexpected.empty()) message += "; unexpected joints: " + list(unexpected);
  if (!wrong_parent.empty()) message += "; a different parent: " + list(wrong_parent);
  throw InputError(message);
}

namespace {

// Frames k = 0 .. frames - 1 at `rate_hz` from the file's frame `first`,
// each the file's frame nearest to first + k / rate_hz s (ties to the
// later), never past its last frame. At the file's own rate, its frames.
MotionFrames import_frames(const Skeleton& skeleton, const std::vector<int>& match, const BvhFile& file,
                           const std::string& source_name, int64_t first, int64_t frames,
                           double rate_hz = kBvhImportRate) {
  const bool own_rate = rate_hz <= 0;
  const double unit = skeleton.bvh ? skeleton.bvh->millimetres_per_unit : 1.0;
  const int64_t source_frames = file.frame_count();
  const int channels = file.channel_count();
  const int columns = skeleton_motion_columns(skeleton);
  const std::vector<int> first_channel = file.first_channels();

  MotionFrames motion;
  motion.columns = columns;
  motion.values.assign(static_cast<size_t>(frames) * columns, 0.0f);
  Vec3 previous{0, 0, 0};
  for (int64_t k = 0; k < frames; ++k) {
    const double t = own_rate ? 0.0 : static_cast<double>(k) / rate_hz;
    int64_t source = own_rate ? first + k : first + static_cast<int64_t>(std::floor(t / file.frame_time_s + 0.5));
    if (source > source_frames - 1) source = source_frames - 1;
    const double* values = file.values.data() + source * channels;
    float* out = motion.frame(k);
    for (size_t j = 0; j < match.size(); ++j) {
      if (match[j] < 0) continue;
      const BvhJoint& joint = file.joints[match[j]];
      Mat3 local = identity_matrix();
      Vec3 position{0, 0, 0};
      for (size_t c = 0; c < joint.channels.size(); ++c) {
        const double value = values[first_channel[match[j]] + c];
        const int axis = bvh_channel_axis(joint.channels[c]);
        if (bvh_channel_is_position(joint.channels[c])) {
          position[axis] = value * unit;
        } else {
          local = multiply(local, axis_rotation(axis, value * kPi / 180.0));
        }
      }
      const Vec3 e = matrix_to_expmap(transpose(local));
      for (int c = 0; c < 3; ++c) out[3 + 3 * j + c] = static_cast<float>(e[c]);
      if (j == 0) {
        for (int c = 0; c < 3; ++c) {
          // Frame 0's change is the root's start, so that the running sum
          // is the file's own positions and a reply keeps where it was.
          const double change = k == 0 ? position[c] : position[c] - previous[c];
          if (std::fabs(change) > kMaxRootTranslationMm) {
            throw InputError(source_name + (k == 0 ? ": the root starts " + std::to_string(change) +
                                                         " mm from the origin, more than "
                                                   : ": the root moves " + std::to_string(change) + " mm between " +
                                                         (own_rate ? std::string("") : std::string("25 Hz ")) +
                                                         "frames " + std::to_string(k - 1) + " and " +
                                                         std::to_string(k) + ", more than ") +
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

std::string seconds(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace

MotionFrames skeleton_motion_from_bvh(const Skeleton& skeleton, const BvhFile& file, const std::string& source_name,
                                      const BvhFrameLimit& limit) {
  const std::vector<int> match = match_bvh_to_skeleton(skeleton, file, source_name);
  const int64_t source_frames = file.frame_count();
  if (source_frames < 1) throw InputError(source_name + ": no frames");
  const int64_t frames = bvh_imported_frame_count(source_frames, file.frame_time_s);
  if (frames > limit.frames) {
    throw InputError(source_name + ": " + std::to_string(source_frames) + " frames of " + seconds(file.frame_time_s) +
                     " s make " + std::to_string(frames) + " frames at 25 Hz, more than the " +
                     std::to_string(limit.frames) + " of " + limit.name);
  }
  return import_frames(skeleton, match, file, source_name, 0, frames);
}

MotionFrames skeleton_motion_window_from_bvh(const Skeleton& skeleton, const BvhFile& file,
                                             const std::string& source_name, int64_t first_frame, int64_t frames) {
  const std::vector<int> match = match_bvh_to_skeleton(skeleton, file, source_name);
  const int64_t source_frames = file.frame_count();
  if (first_frame < 0 || first_frame >= source_frames) {
    throw InputError(source_name + ": frame " + std::to_string(first_frame) + " is not one of its " +
                     std::to_string(source_frames) + " frames");
  }
  const int64_t available = bvh_imported_frame_count(source_frames - first_frame, file.frame_time_s);
  if (frames < 0 || frames > available) {
    throw InputError(source_name + ": from frame " + std::to_string(first_frame) + " it makes " +
                     std::to_string(available) + " frames at 25 Hz, fewer than the " + std::to_string(frames) +
                     " asked for");
  }
  return import_frames(skeleton, match, file, source_name, first_frame, frames);
}

MotionFrames skeleton_motion_from_bvh_at_file_rate(const Skeleton& skeleton, const BvhFile& file,
                                                  const std::string& source_name) {
  const std::vector<int> match = match_bvh_to_skeleton(skeleton, file, source_name);
  if (file.frame_count() < 1) throw InputError(source_name + ": no frames");
  return import_frames(skeleton, match, file, source_name, 0, file.frame_count(), 0.0);
}

}  // namespace mm
