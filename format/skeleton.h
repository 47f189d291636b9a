// Skeleton: joint names, parents and bone offsets (mm) of a kinematic tree,
// the data forward kinematics needs besides the joint angles.
//
// The JSON layout is that of shared/data/h36m-skeleton.json:
//   {"name": "...", "joints": [{"index": 0, "name": "Hips", "parent": -1,
//                               "offset": [x, y, z]}, ...]}
// and, for a skeleton derived from a BVH file, its channel layout there:
//   "bvh": {"millimetres_per_unit": 10, "joints": [{"channels": ["Xposition",
//           ..., "Zrotation"], "end_site": false}, ...]}   (one per joint)
// Other keys are ignored. Plain value types; all functions are reentrant.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace mm {

struct Joint {
  std::string name;
  int parent = -1;                     // index of the parent joint, -1 for the root
  std::array<double, 3> offset_mm{};   // bone offset from the parent, millimetres
};

// How the joints of a skeleton derived from a BVH file (bvh_skeleton() in
// bvh_file.h) were laid out in that file: without it a motion could only be
// written back as BVH of some default rig (rotation order, End Sites and unit
// are not in the kinematics), which animation tools would not map onto the
// user's own.
struct BvhLayout {
  double millimetres_per_unit = 1.0;  // the file's length unit: 10 for cm, 1 for mm
  // Per skeleton joint, its channels in file order as the file spells them
  // ("Xposition" ... "Zrotation"), none twice, at most 6; none for an End Site.
  std::vector<std::vector<std::string>> channels;
  std::vector<bool> end_site;  // per skeleton joint: an End Site (a leaf without a name in the file)
};

struct Skeleton {
  std::string name;
  std::vector<Joint> joints;  // parents always precede children; joint 0 is the root
  // The BVH layout this skeleton came from, when it came from one; H3.6M's has none.
  std::optional<BvhLayout> bvh;

  // joints.size().
  int joint_count() const;

  // The built-in 32-joint H3.6M skeleton (name "h36m-32"), identical to
  // shared/data/h36m-skeleton.json. Never throws.
  static Skeleton h36m();

  // Parses and validates the JSON layout above. `source_name` names the
  // document in error messages. Throws InputError naming the joint and the
  // field when: the text is not JSON, "name" or "joints" is missing, there are
  // no joints, "index" differs from the joint's position, "name" is empty or
  // repeated, "parent" is not -1 for joint 0 or not in [0, index) for the
  // others, "offset" is not 3 finite numbers, or a "bvh" layout is present
  // and malformed (another joint count, a channel name not among the six, a
  // repeated channel, more than 6, an End Site with channels or children, a
  // unit that is not a positive finite number).
  static Skeleton from_json_text(const std::string& text, const std::string& source_name);

  // JSON in the layout above; from_json_text(to_json_text()) reproduces the
  // skeleton exactly (offsets are written with round-trip precision).
  std::string to_json_text() const;
};

// Reads and parses a skeleton JSON file. Throws InputError naming `path` when
// it cannot be read or is invalid.
Skeleton read_skeleton_file(const std::string& path);

}  // namespace mm
