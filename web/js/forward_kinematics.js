// Forward kinematics of exponential-map frames of a skeleton (H3.6M's, or a
// rig learnt from BVH files; model_skeletons.js), as the model computes it
// (model/forward_kinematics.h): the row-vector convention of the skeleton
// file, R_world[j] = R_local[j] . R_world[parent] and
// p[j] = offset[j] . R_world[parent] + p[parent], root at the origin (the
// model does not learn the root translation, columns 0..2).

// Rotation matrix (row-major, 9 numbers) of an exponential map, with the
// skew matrix of Martinez et al.'s expmap2rotmat ([[0,-z,y],[z,0,-x],[-y,x,0]]).
export function expmapToMatrix(x, y, z) {
  const theta2 = x * x + y * y + z * z;
  // The series of sin(t)/t and (1-cos t)/t^2 near zero, as model/rotation.cpp.
  const small = theta2 < 1e-8;
  const theta = Math.sqrt(theta2);
  const a = small ? 1 - theta2 / 6 : Math.sin(theta) / theta;
  const b = small ? 0.5 - theta2 / 24 : (1 - Math.cos(theta)) / theta2;
  const k = [0, -z, y, z, 0, -x, -y, x, 0];
  const kk = multiply(k, k);
  const r = new Array(9);
  for (let i = 0; i < 9; ++i) r[i] = (i % 4 === 0 ? 1 : 0) + a * k[i] + b * kk[i];
  return r;
}

function multiply(p, q) {
  const r = new Array(9);
  for (let i = 0; i < 3; ++i)
    for (let j = 0; j < 3; ++j)
      r[3 * i + j] = p[3 * i] * q[j] + p[3 * i + 1] * q[3 + j] + p[3 * i + 2] * q[6 + j];
  return r;
}

// Joint positions (mm) of one frame of `skeleton`: a Float64Array of joints x 3.
export function framePositions(values, frameIndex, skeleton) {
  const { parents, offsetsMm, columns } = skeleton;
  const count = parents.length;
  const base = frameIndex * columns;
  const world = new Array(count);
  const positions = new Float64Array(3 * count);
  for (let j = 0; j < count; ++j) {
    const c = base + 3 + 3 * j;
    const local = expmapToMatrix(values[c], values[c + 1], values[c + 2]);
    const parent = parents[j];
    const offset = offsetsMm[j];
    if (parent < 0) {
      world[j] = local;
      positions.set(offset, 0);
      continue;
    }
    const r = world[parent];
    for (let axis = 0; axis < 3; ++axis) {
      positions[3 * j + axis] = offset[0] * r[axis] + offset[1] * r[3 + axis] + offset[2] * r[6 + axis] +
                                positions[3 * parent + axis];
    }
    world[j] = multiply(local, r);
  }
  return positions;
}

// Positions of every frame of a wire motion of `skeleton`.
export function motionPositions(motion, skeleton) {
  if (motion.columns !== skeleton.columns) {
    throw new Error(`a motion of ${motion.columns} values a frame is not one of the skeleton ${skeleton.name} ` +
                    `(${skeleton.columns})`);
  }
  const frames = [];
  for (let f = 0; f < motion.frames; ++f) frames.push(framePositions(motion.values, f, skeleton));
  return frames;
}

// Mean per-joint position error (mm) of two motions of one skeleton over
// their common frames.
export function meanJointErrorMm(a, b) {
  const frames = Math.min(a.length, b.length);
  const joints = frames ? a[0].length / 3 : 0;
  let sum = 0;
  for (let f = 0; f < frames; ++f) {
    for (let j = 0; j < joints; ++j) {
      const dx = a[f][3 * j] - b[f][3 * j], dy = a[f][3 * j + 1] - b[f][3 * j + 1], dz = a[f][3 * j + 2] - b[f][3 * j + 2];
      sum += Math.hypot(dx, dy, dz);
    }
  }
  return sum / (frames * joints);
}
