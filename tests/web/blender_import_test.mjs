// Blender's own BVH importer (Debian's blender, headless) reads the BVH the
// library writes to the joint positions of the library's forward
// kinematics of the motion written, within 0.1 mm (relative to the root,
// every joint that is a bone: End Sites have none): the export of an H3.6M
// clip (the REST API's and the tool's format), and the tool's decode of a
// model of another rig (three CMU dances: 43 joints in cm, each with its own
// rotation order). And the root's travel: an S5 walk encoded and decoded
// by the tool with the model that has a root trajectory network, whose
// decoded root (the running sum of its root moves) travels over a metre,
// lands in Blender where the text says it goes, within 1 mm.
//
//   node blender_import_test.mjs   (ctest: web_blender_imports_our_bvh)
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { exportBvh, referencePositions, s5Clip, writeMotionText } from './fk_reference.mjs';
import { environment, h36mDatasetDir, trainDanceModel } from './server_harness.mjs';

const TOLERANCE_MM = 0.1;
const FRAMES = [0, 74, 149];
const positionsScript = fileURLToPath(new URL('blender_positions.py', import.meta.url));

// Blender's world position of every bone's head at `frames`, in the file's unit.
function blenderHeads(bvhFile, scratch, frames = FRAMES) {
  const out = path.join(scratch, `${path.basename(bvhFile)}.heads.json`);
  execFileSync(environment('MM_BLENDER'), ['--background', '--factory-startup', '--python', positionsScript, '--',
                                            bvhFile, out, frames.join(',')], { stdio: ['ignore', 'ignore', 'inherit'] });
  return JSON.parse(fs.readFileSync(out, 'utf8'));
}

// Compares Blender's heads (times `mmPerUnit`) with `reference` ([frame][joint][xyz]
// mm) for the joints of `skeleton` that are bones; returns how many were compared.
function compare(label, heads, reference, skeleton, mmPerUnit) {
  const root = skeleton.joints[0].name;
  let compared = 0, largest = 0;
  skeleton.joints.forEach(({ name }, j) => {
    if (!heads[name]) return;
    compared += 1;
    FRAMES.forEach((frame, i) => {
      const drawn = [0, 1, 2].map((a) => (heads[name][i][a] - heads[root][i][a]) * mmPerUnit);
      const want = [0, 1, 2].map((a) => reference[frame][j][a] - reference[frame][0][a]);
      const distance = Math.hypot(...drawn.map((v, a) => v - want[a]));
      largest = Math.max(largest, distance);
      assert.ok(distance < TOLERANCE_MM, `${label}: ${name} at frame ${frame} lies ${distance} mm from our FK`);
    });
  });
  console.log(`${label}: ${compared} joints at frames ${FRAMES.join(', ')}, largest distance from our FK ` +
              `${largest.toExponential(2)} mm`);
  return compared;
}

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'mm-blender-'));
try {
  // H3.6M: an S5 clip and the library's export of it.
  const h36m = JSON.parse(fs.readFileSync(path.join(environment('MM_SOURCE_DIR'), 'models/h36m-dkgm-cpu/manifest.json'), 'utf8')).skeleton;
  const clipFile = path.join(scratch, 'walking.txt');
  writeMotionText(clipFile, s5Clip(h36mDatasetDir(), 'walking_1.txt'));
  const clipBvh = path.join(scratch, 'walking.bvh');
  exportBvh(clipFile, clipBvh);
  assert.equal(compare('H3.6M walking', blenderHeads(clipBvh, scratch), referencePositions(clipFile), h36m, 1), 25);

  // The walk's code, decoded with a root trajectory network: text and BVH.
  const tool = environment('MM_TOOL');
  const trajectoryModel = path.join(environment('MM_SOURCE_DIR'), 'models/h36m-dkgm-h100');
  const walkCode = path.join(scratch, 'walk_code.json');
  fs.writeFileSync(walkCode, execFileSync(tool, ['encode', '--model', trajectoryModel, '--input', clipFile, '--rate', '25']));
  const walkText = path.join(scratch, 'walk_decoded.txt'), walkBvh = path.join(scratch, 'walk_decoded.bvh');
  for (const out of [walkText, walkBvh]) execFileSync(tool, ['decode', '--model', trajectoryModel, '--code', walkCode, '--out', out]);
  // The text's root at frame f: the running sum of its columns 0..2 over frames 0..f.
  const rows = fs.readFileSync(walkText, 'utf8').trim().split('\n').map((row) => row.split(',').map(Number));
  const rootAt = (frame) => [0, 1, 2].map((axis) => rows.slice(0, frame + 1).reduce((sum, row) => sum + row[axis], 0));
  const horizontal = (a, b) => Math.hypot(b[0] - a[0], b[2] - a[2]);
  const textTravel = horizontal(rootAt(0), rootAt(149));
  // blender_positions.py imports with axis_forward Y and axis_up Z, Blender's
  // own axes: no conversion, so the heads are in the file's axes (as the FK
  // comparisons above rely on), y up, and the floor is their x and z.
  const [hipsAt0, hipsAt149] = blenderHeads(walkBvh, scratch, [0, 149]).Hips;
  const blenderTravel = horizontal(hipsAt0, hipsAt149);
  console.log(`decoded walk: the root moves ${blenderTravel.toFixed(3)} mm horizontally in Blender from frame 0 to 149, ` +
              `${textTravel.toFixed(3)} mm in the decoded text`);
  assert.ok(Math.abs(blenderTravel - textTravel) < 1, `Blender's root travels ${blenderTravel} mm, the text's ${textTravel} mm`);
  // The same way too, not only as far: each floor axis's move agrees.
  for (const axis of [0, 2]) {
    const blenderMove = hipsAt149[axis] - hipsAt0[axis], textMove = rootAt(149)[axis] - rootAt(0)[axis];
    assert.ok(Math.abs(blenderMove - textMove) < 1, `axis ${axis}: Blender's root moves ${blenderMove} mm, the text's ${textMove} mm`);
  }
  assert.ok(textTravel > 1000, `a decoded walk travels only ${textTravel} mm in 6 s`);

  // A rig learnt from BVH files: one code decoded by the tool as text and as BVH.
  const { model } = trainDanceModel(scratch);
  const rig = JSON.parse(fs.readFileSync(path.join(model, 'manifest.json'), 'utf8')).skeleton;
  const rigFile = path.join(scratch, 'dances-skeleton.json');
  fs.writeFileSync(rigFile, JSON.stringify(rig));
  const codeFile = path.join(scratch, 'code.json');
  fs.writeFileSync(codeFile, JSON.stringify({ code: Array.from({ length: 64 }, (_, i) => Math.sin(i + 1)) }));
  const decoded = (out) => execFileSync(environment('MM_TOOL'), ['decode', '--model', model, '--code', codeFile, '--out', out]);
  const danceText = path.join(scratch, 'dance.txt'), danceBvh = path.join(scratch, 'dance.bvh');
  decoded(danceText);
  decoded(danceBvh);
  const compared = compare('CMU dance rig', blenderHeads(danceBvh, scratch), referencePositions(danceText, rigFile), rig,
                           rig.bvh.millimetres_per_unit);
  assert.equal(compared, 43);
} finally {
  fs.rmSync(scratch, { recursive: true, force: true });
}
