// The built-in H3.6M skeleton as constants, so that a model and a client agree
// on it without shipping a JSON file.
//
// Source: Martinez, Black and Romero, "On human motion prediction using
// recurrent neural networks" (CVPR 2017), public code
// github.com/una-dinosauria/human-motion-prediction, src/forward_kinematics.py,
// _some_variables() (parent and offset arrays; the same numbers appear in
// QuaterNet). Names follow the common Human3.6M 32-joint order. The table is
// shared/data/h36m-skeleton.json verbatim; a test checks they stay equal.
#include "format/skeleton.h"

#include <iterator>

namespace mm {
namespace {

struct JointRow {
  const char* name;
  int parent;
  double offset[3];  // mm
};

constexpr JointRow kH36mJoints[] = {
    {"Hips", -1, {0.0, 0.0, 0.0}},
    {"RightUpLeg", 0, {-132.948591, 0.0, 0.0}},
    {"RightLeg", 1, {0.0, -442.894612, 0.0}},
    {"RightFoot", 2, {0.0, -454.206447, 0.0}},
    {"RightToeBase", 3, {0.0, 0.0, 162.767078}},
    {"RightToeBase_End", 4, {0.0, 0.0, 74.999437}},
    {"LeftUpLeg", 0, {132.948826, 0.0, 0.0}},
    {"LeftLeg", 6, {0.0, -442.894413, 0.0}},
    {"LeftFoot", 7, {0.0, -454.20659, 0.0}},
    {"LeftToeBase", 8, {0.0, 0.0, 162.767426}},
    {"LeftToeBase_End", 9, {0.0, 0.0, 74.999948}},
    {"Spine", 0, {0.0, 0.1, 0.0}},
    {"Spine1", 11, {0.0, 233.383263, 0.0}},
    {"Neck", 12, {0.0, 257.077681, 0.0}},
    {"Head", 13, {0.0, 121.134938, 0.0}},
    {"Head_End", 14, {0.0, 115.002227, 0.0}},
    {"LeftShoulder", 12, {0.0, 257.077681, 0.0}},
    {"LeftArm", 16, {0.0, 151.034226, 0.0}},
    {"LeftForeArm", 17, {0.0, 278.882773, 0.0}},
    {"LeftHand", 18, {0.0, 251.733451, 0.0}},
    {"LeftHandThumb", 19, {0.0, 0.0, 0.0}},
    {"LeftHandThumb_End", 20, {0.0, 0.0, 99.999627}},
    {"LeftWrist_End", 19, {0.0, 100.000188, 0.0}},
    {"LeftWrist_End_Site", 22, {0.0, 0.0, 0.0}},
    {"RightShoulder", 12, {0.0, 257.077681, 0.0}},
    {"RightArm", 24, {0.0, 151.031437, 0.0}},
    {"RightForeArm", 25, {0.0, 278.892924, 0.0}},
    {"RightHand", 26, {0.0, 251.72868, 0.0}},
    {"RightHandThumb", 27, {0.0, 0.0, 0.0}},
    {"RightHandThumb_End", 28, {0.0, 0.0, 99.999888}},
    {"RightWrist_End", 27, {0.0, 137.499922, 0.0}},
    {"RightWrist_End_Site", 30, {0.0, 0.0, 0.0}},
};

}  // namespace

Skeleton Skeleton::h36m() {
  Skeleton skeleton;
  skeleton.name = "h36m-32";
  skeleton.joints.reserve(std::size(kH36mJoints));
  for (const JointRow& row : kH36mJoints) {
    skeleton.joints.push_back(Joint{row.name, row.parent, {row.offset[0], row.offset[1], row.offset[2]}});
  }
  return skeleton;
}

}  // namespace mm
