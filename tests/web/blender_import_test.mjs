// Blender's own BVH importer (Debian's blender, headless) reads the BVH the
// library writes to the joint positions of the library's forward
// kinematics of the motion written, within 0.1 mm (relative to the root,
// every joint that is a bone: End Sites have none): the export of an H3.6M
// clip (the REST API's and the tool's format), and the tool's decode of a
// model of another rig (three CMU dances: 43 joints in cm, each with its own
// rotation order).
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

// Blender's world position of every bone's head at FRAMES, in the file's unit.
function blenderHeads(bvhFile, scratch) {
  const out = path.join(scratch, `${path.basename(bvhFile)}.heads.json`);
  execFileSync(environment('MM_BLENDER'), ['--background', '--factory-startup', '--python', positionsScript, '--',
                                            bvhFile, out, FRAMES.join(',')], { stdio: ['ignore', 'ignore', 'inherit'] });
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
