// The skeleton of a model's motions as the server describes it (GET
// v1/models/NAME: joint names, parents and offsets in mm): H3.6M's 32
// joints, or the rig a model learnt from BVH files. The page draws every
// motion with the skeleton of the model that answered for it, asked once a
// model version (a folder replaced under the same name is asked again).
import { callApi } from './api_client.js';

const described = new Map();  // "<model> <version>" -> Promise of its skeleton

// { name, jointNames, parents, offsetsMm, columns } of the motions of
// `model` at `version` (as a reply's answered_by names them).
export function skeletonOf(model, version) {
  const key = `${model} ${version}`;
  if (!described.has(key)) {
    const asked = callApi('GET', `v1/models/${encodeURIComponent(model)}`).then((info) => {
      const joints = info.skeleton?.joints;
      if (!Array.isArray(joints) || joints.length === 0) throw new Error(`the server describes no skeleton for model ${model}`);
      return {
        name: info.skeleton.name,
        jointNames: joints.map((joint) => joint.name),
        parents: joints.map((joint) => joint.parent),
        offsetsMm: joints.map((joint) => joint.offset),
        columns: 3 + 3 * joints.length,
      };
    });
    // A failed description is asked again next time.
    asked.catch(() => described.delete(key));
    described.set(key, asked);
  }
  return described.get(key);
}

// The layout of motions of `columns` values a frame, as the server names it.
export function layoutOfColumns(columns) {
  return columns === 99 ? 'h36m-expmap-99' : `expmap-${columns}`;
}
