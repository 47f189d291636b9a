// Motions read from files the user picks: exponential-map text
// (comma-separated values, a frame a line: H3.6M's 99, or a rig's) and BVH
// of a model's skeleton. The page never judges a file itself: what it reads
// goes to the server, whose error (a wrong column count, too few frames,
// another skeleton) is the one shown.
import { BVHLoader } from 'three/addons/loaders/BVHLoader.js';
import { layoutOfColumns } from './model_skeletons.js';

export const MODEL_RATE = 25;
export const MODEL_FRAMES = 150;

// The wire motion of the model's window of a text file: 150 frames at 25 Hz,
// or 300 at 50 Hz (the data set's rate; the server keeps every second
// frame), from frame `start` of the file. A short or malformed file gives
// whatever it holds, for the server to refuse.
export function textWindow(text, rate, start) {
  const rows = text.split(/\r?\n/).filter((line) => line.trim() !== '');
  const wanted = rate === 50 ? 2 * MODEL_FRAMES : MODEL_FRAMES;
  const window = rows.slice(start, start + wanted).map((line) => line.split(',').map(Number));
  const columns = window.length ? window[0].length : 0;
  return { frames: window.length, columns, frame_rate: rate, layout: layoutOfColumns(columns), values: window.flat() };
}

// A wire motion at the model's 25 Hz, as the server takes a 50 Hz one:
// every second frame, from the first.
export function atModelRate(motion) {
  if (motion.frame_rate === MODEL_RATE) return motion;
  const step = Math.round(motion.frame_rate / MODEL_RATE);
  const frames = Math.ceil(motion.frames / step);
  const values = [];
  for (let f = 0; f < motion.frames; f += step)
    values.push(...motion.values.slice(f * motion.columns, (f + 1) * motion.columns));
  return { ...motion, frames, frame_rate: MODEL_RATE, values };
}

// A whole text file as a wire motion at `rate` (a take: every row). A
// malformed file gives whatever it holds, for the server to refuse.
export function textTake(text, rate) {
  const rows = text.split(/\r?\n/).filter((line) => line.trim() !== '').map((line) => line.split(',').map(Number));
  const columns = rows.length ? rows[0].length : 0;
  return { frames: rows.length, columns, frame_rate: rate, layout: layoutOfColumns(columns), values: rows.flat() };
}

// A BVH of `skeleton` (model_skeletons.js) as a 25 Hz wire motion, as the
// server reads one for a clip.
export function bvhToModelRateMotion(text, skeleton) {
  return bvhToMotion(text, skeleton, MODEL_RATE);
}

// A BVH of `skeleton` as a wire motion at `rate` (null: every frame of the
// file at its own rate, as the server reads a take), through three.js's
// BVHLoader: the inverse of format/skeleton_bvh.h, joints
// matched by name (the root's translation is left at zero: the model does
// not learn it). A joint's local
// rotation in the row-vector convention is the transpose of the BVH's
// (column-vector) rotation, so its exponential map is minus the axis-angle
// of the BVH quaternion. Frames are resampled by taking the file's
// frame nearest in time (ties to the later), as the server does. Joints
// absent from the file (the leaves written as End Sites) are unrotated.
export function bvhToMotion(text, skeleton, rate = null) {
  const { columns, jointNames } = skeleton;
  const { clip } = new BVHLoader().parse(text);
  const tracks = new Map(clip.tracks.map((track) => [track.name, track]));
  const anyTrack = clip.tracks[0];
  const fileFrames = anyTrack.times.length;
  // From the text: the loader's times are float32, whose rounding can lose a frame here.
  const frameTime = Number(/Frame Time:\s*(\S+)/i.exec(text)?.[1] ?? 1 / MODEL_RATE);
  const outRate = rate ?? 1 / frameTime;
  const outFrames = rate === null ? fileFrames : Math.floor((fileFrames - 1) * frameTime * outRate + 1e-6) + 1;
  const values = new Array(outFrames * columns).fill(0);
  for (let k = 0; k < outFrames; ++k) {
    const source = rate === null ? k : Math.min(fileFrames - 1, Math.floor(k / outRate / frameTime + 0.5));
    jointNames.forEach((name, j) => {
      const track = tracks.get(`${name}.quaternion`);
      if (!track) return;
      const [x, y, z, w] = track.values.slice(4 * source, 4 * source + 4);
      const s = Math.hypot(x, y, z);
      // Angle in [0, pi]: q and -q are the same rotation.
      const angle = 2 * Math.atan2(s, Math.abs(w));
      const scale = s < 1e-12 ? 0 : -Math.sign(w || 1) * angle / s;
      values.splice(k * columns + 3 + 3 * j, 3, scale * x, scale * y, scale * z);
    });
  }
  return { frames: outFrames, columns, frame_rate: outRate, layout: layoutOfColumns(columns), values };
}
