// three.js's BVHLoader reads the BVH export of the H3.6M skeleton to the
// same joint positions as our forward kinematics, within 0.1 mm: for the
// REST API's BVH reply (the default export: Z Y X rotation channels) and for
// the library's export with other rotation orders and position channels on
// every joint. three computes the positions: BVHLoader's skeleton, posed
// from its own animation tracks at a frame, then its world matrices.
//
//   node bvh_loader_test.mjs NODE_MODULES   (ctest: web_bvh_loader_reads_our_export)
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { exportBvh, largestDistanceMm, referencePositions, s5Clip, writeMotionText } from './fk_reference.mjs';
import { h36mDatasetDir, startServer } from './server_harness.mjs';

const TOLERANCE_MM = 0.1;
const FRAMES = [0, 37, 74, 111, 149];
const nodeModules = process.argv[2];
const THREE = await import(pathToFileURL(path.join(nodeModules, 'three/build/three.module.js')));
const { BVHLoader } = await import(pathToFileURL(path.join(nodeModules, 'three/examples/jsm/loaders/BVHLoader.js')));
// World positions of the joints of `ours` (the skeleton as the server
// describes it: H3.6M's 32 joints) at `frame`, relative to the root, as three
// poses the loaded skeleton. Our 7 leaves are the BVH's End Sites, which
// BVHLoader names ENDSITE under their parent's bone.
function threePositions({ skeleton, clip }, frame, ours) {
  const bones = new Map(skeleton.bones.filter((b) => b.name !== 'ENDSITE').map((b) => [b.name, b]));
  for (const track of clip.tracks) {
    const [name, property] = track.name.split('.');
    const size = property === 'quaternion' ? 4 : 3;
    bones.get(name)[property].fromArray(track.values, size * frame);
  }
  const root = skeleton.bones[0];
  root.updateMatrixWorld(true);
  const rootPosition = root.getWorldPosition(new THREE.Vector3());
  return ours.joints.map(({ name, parent }) => {
    const bone = bones.get(name) ?? bones.get(ours.joints[parent].name).children.find((c) => c.name === 'ENDSITE');
    assert.ok(bone, `joint ${name} is not in the loaded BVH`);
    return bone.getWorldPosition(new THREE.Vector3()).sub(rootPosition).toArray();
  });
}

function checkBvh(label, bvhText, reference, ours) {
  const loaded = new BVHLoader().parse(bvhText);
  assert.equal(loaded.clip.tracks[0].times.length, reference.length, `${label}: frame count`);
  for (const frame of FRAMES) {
    const distance = largestDistanceMm(threePositions(loaded, frame, ours), reference[frame]);
    assert.ok(distance < TOLERANCE_MM, `${label}, frame ${frame}: a joint lies ${distance.toFixed(4)} mm from our FK`);
    console.log(`${label}, frame ${frame}: largest joint distance ${distance.toExponential(2)} mm`);
  }
}

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-bvh-loader-'));
const server = await startServer();
try {
  const { skeleton: h36m } = await server.call('GET', 'v1/models/h36m-dkgm-cpu');
  assert.equal(h36m.joints.length, 32);
  // The library's export of an S5 clip, with each set of options it offers.
  const clipFile = path.join(scratch, 'walking.txt');
  writeMotionText(clipFile, s5Clip(h36mDatasetDir(), 'walking_1.txt'));
  const clipReference = referencePositions(clipFile);
  for (const options of [{}, { rotationOrder: 'XYZ', positionChannels: true }, { rotationOrder: 'YXZ' }]) {
    const bvh = exportBvh(clipFile, path.join(scratch, 'walking.bvh'), options);
    if (options.positionChannels) assert.match(bvh, /JOINT RightLeg\s*\{\s*OFFSET[^\n]*\n\s*CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation/);
    checkBvh(`S5 walking, export ${JSON.stringify(options)}`, bvh, clipReference, h36m);
  }

  // The REST API's BVH of a decoded motion (Accept: application/x-bvh).
  const { codes } = await server.call('POST', 'v1/sample', { count: 1, seed: 11 });
  const { motions } = await server.call('POST', 'v1/decode', { codes });
  const decodedFile = path.join(scratch, 'decoded.txt');
  writeMotionText(decodedFile, motions[0]);
  const reply = await fetch(`${server.direct}/v1/decode`, {
    method: 'POST', headers: { Accept: 'application/x-bvh', 'Content-Type': 'application/json' }, body: JSON.stringify({ codes }) });
  assert.equal(reply.status, 200);
  checkBvh('REST decode as BVH', await reply.text(), referencePositions(decodedFile), h36m);
  console.log('BVHLoader reads every export to our FK positions');
} finally {
  await server.stop();
  fs.rmSync(scratch, { recursive: true, force: true });
}
