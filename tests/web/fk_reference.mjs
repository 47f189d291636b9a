// The model library's forward kinematics and BVH export of a wire motion,
// through web_fk_reference (fk_reference.cpp).
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { environment } from './server_harness.mjs';

// Writes a 25 Hz wire motion as text of its columns.
export function writeMotionText(file, motion) {
  const rows = [];
  for (let f = 0; f < motion.frames; ++f) rows.push(motion.values.slice(f * motion.columns, (f + 1) * motion.columns).join(','));
  fs.writeFileSync(file, `${rows.join('\n')}\n`);
}

// Positions [frame][joint][xyz] in mm of a 25 Hz text file, or of a BVH file
// read as the server reads one, of H3.6M's skeleton or of the skeleton in
// the JSON file `skeletonFile`.
export function referencePositions(motionFile, skeletonFile) {
  const args = skeletonFile ? [motionFile, '--skeleton', skeletonFile] : [motionFile];
  return JSON.parse(execFileSync(environment('MM_FK_REFERENCE'), args, { maxBuffer: 256 << 20 }).toString());
}

// The library's BVH of a 25 Hz text file, with export options.
export function exportBvh(textFile, bvhFile, { rotationOrder, positionChannels } = {}) {
  const args = [textFile, '--bvh', bvhFile];
  if (rotationOrder) args.push('--rotation-order', rotationOrder);
  if (positionChannels) args.push('--position-channels');
  execFileSync(environment('MM_FK_REFERENCE'), args);
  return fs.readFileSync(bvhFile, 'utf8');
}

// The largest distance (mm) between two lists of [x, y, z] joint positions.
export function largestDistanceMm(a, b) {
  if (a.length !== b.length) throw new Error(`joint counts differ: ${a.length} and ${b.length}`);
  return Math.max(...a.map((p, j) => Math.hypot(p[0] - b[j][0], p[1] - b[j][1], p[2] - b[j][2])));
}

// Frames 0..149 of an S5 take at 25 Hz: every second line of the 50 Hz file.
export function s5Clip(datasetDir, take) {
  const lines = fs.readFileSync(path.join(datasetDir, 'S5', take), 'utf8').split('\n').filter((l) => l.trim());
  const rows = lines.filter((_, i) => i % 2 === 0).slice(0, 150);
  return { frames: rows.length, columns: 99, frame_rate: 25, layout: 'h36m-expmap-99', values: rows.flatMap((r) => r.split(',').map(Number)) };
}
