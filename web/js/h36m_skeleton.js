// The 32-joint H3.6M skeleton the models are trained on: names, parents and
// bone offsets in mm, as model/format/h36m_skeleton.cpp has them (the same
// table as shared/data/h36m-skeleton.json). The browser test checks the
// positions drawn from it against the server's forward kinematics.
const JOINTS = [
  ['Hips', -1, [0, 0, 0]],
  ['RightUpLeg', 0, [-132.948591, 0, 0]],
  ['RightLeg', 1, [0, -442.894612, 0]],
  ['RightFoot', 2, [0, -454.206447, 0]],
  ['RightToeBase', 3, [0, 0, 162.767078]],
  ['RightToeBase_End', 4, [0, 0, 74.999437]],
  ['LeftUpLeg', 0, [132.948826, 0, 0]],
  ['LeftLeg', 6, [0, -442.894413, 0]],
  ['LeftFoot', 7, [0, -454.20659, 0]],
  ['LeftToeBase', 8, [0, 0, 162.767426]],
  ['LeftToeBase_End', 9, [0, 0, 74.999948]],
  ['Spine', 0, [0, 0.1, 0]],
  ['Spine1', 11, [0, 233.383263, 0]],
  ['Neck', 12, [0, 257.077681, 0]],
  ['Head', 13, [0, 121.134938, 0]],
  ['Head_End', 14, [0, 115.002227, 0]],
  ['LeftShoulder', 12, [0, 257.077681, 0]],
  ['LeftArm', 16, [0, 151.034226, 0]],
  ['LeftForeArm', 17, [0, 278.882773, 0]],
  ['LeftHand', 18, [0, 251.733451, 0]],
  ['LeftHandThumb', 19, [0, 0, 0]],
  ['LeftHandThumb_End', 20, [0, 0, 99.999627]],
  ['LeftWrist_End', 19, [0, 100.000188, 0]],
  ['LeftWrist_End_Site', 22, [0, 0, 0]],
  ['RightShoulder', 12, [0, 257.077681, 0]],
  ['RightArm', 24, [0, 151.031437, 0]],
  ['RightForeArm', 25, [0, 278.892924, 0]],
  ['RightHand', 26, [0, 251.72868, 0]],
  ['RightHandThumb', 27, [0, 0, 0]],
  ['RightHandThumb_End', 28, [0, 0, 99.999888]],
  ['RightWrist_End', 27, [0, 137.499922, 0]],
  ['RightWrist_End_Site', 30, [0, 0, 0]],
];

export const H36M_JOINT_NAMES = JOINTS.map(([name]) => name);
export const H36M_PARENTS = JOINTS.map(([, parent]) => parent);
export const H36M_OFFSETS_MM = JOINTS.map(([, , offset]) => offset);
export const H36M_JOINT_COUNT = JOINTS.length;  // 32
// Root translation (3) then an exponential map per joint (3 x 32).
export const H36M_COLUMNS = 3 + 3 * JOINTS.length;  // 99
