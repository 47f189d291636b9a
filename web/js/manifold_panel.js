// The manifold at work: each button is one operation of the REST API
// (encode and decode for a reconstruction, two denoise calls for projected
// and filled, POST /v1/join for two clips joined by a transition), its result drawn in the view, with the skeleton of the model
// that answered, and kept on the shelf.
import { callApi, callWithToken } from './api_client.js';
import { runAction } from './call_log.js';
import { clipWindowPath, showClipBounds } from './data_root_clips.js';
import { meanJointErrorMm, motionPositions } from './forward_kinematics.js';
import { skeletonOf } from './model_skeletons.js';
import { corruptZeroed } from './paper_corruption.js';
import { atModelRate, bvhToModelRateMotion, textWindow } from './motion_files.js';
import { bindMenu, operand, shelfEntry, shelve } from './motion_shelf.js';
import { rootPath } from './root_path.js';

const $ = (id) => document.getElementById(id);
const decoder = () => $('decoder').value;  // '' is the model's default

// A generated motion travels along its root path; any other stands at the origin.
function figure(label, motion, skeleton) {
  const atRate = atModelRate(motion);
  return { label, positions: motionPositions(atRate, skeleton), parents: skeleton.parents, frameRate: 25,
           rootPath: rootPath(atRate) };
}

// The skeleton of the model that answered `reply`.
function skeletonOfReply(reply) {
  return skeletonOf(reply.answered_by.model, reply.answered_by.version);
}

// A shelf entry drawn as a figure.
function entryFigure(label, entry) {
  return figure(label, entry.motion, entry.skeleton);
}

function say(text) {
  $('result').textContent = text;
}

function answeredBy(reply) {
  return `answered by ${reply.answered_by.model} (${reply.answered_by.version})`;
}

async function decodeCode(code) {
  const reply = await callApi('POST', 'v1/decode', { body: { codes: [code], decoder: decoder() } });
  return reply.motions[0];
}

// A reconstruction: the code the server encoded `original` (a 25 Hz motion
// of `skeleton`) into is decoded back; both are drawn side by side, with the
// reconstruction's error, and shelved.
async function showReconstruction(view, name, original, skeleton, encoded) {
  const code = encoded.codes[0];
  const reconstruction = await decodeCode(code);
  shelve(name, original, skeleton, code);
  shelve(`${name} reconstructed`, reconstruction, skeleton, code);
  const error = meanJointErrorMm(motionPositions(original, skeleton), motionPositions(reconstruction, skeleton));
  view.show([figure(name, original, skeleton), figure(`reconstruction (${error.toFixed(1)} mm)`, reconstruction, skeleton)]);
  say(`reconstruction error ${error.toFixed(1)} mm (mean per-joint position error); ${answeredBy(encoded)}`);
}

// Upload: the file goes to the server as it is (JSON for text, the BVH
// itself for .bvh); the page reads a BVH in the skeleton of the model that
// encoded it, to draw it.
async function reconstructUpload(view) {
  const file = $('upload-file').files[0];
  if (!file) throw new Error('choose a text file (H3.6M exponential maps) or a BVH file first');
  const text = await file.text();
  const isBvh = file.name.toLowerCase().endsWith('.bvh');
  if (isBvh) {
    const encoded = await callApi('POST', 'v1/encode', { body: text, contentType: 'application/x-bvh', summary: file.name });
    const skeleton = await skeletonOfReply(encoded);
    await showReconstruction(view, file.name, bvhToModelRateMotion(text, skeleton), skeleton, encoded);
    return;
  }
  const clip = textWindow(text, Number($('upload-rate').value), Number($('upload-start').value));
  const encoded = await callApi('POST', 'v1/encode', { body: { motions: [clip] }, summary: file.name });
  await showReconstruction(view, `${file.name} @${$('upload-start').value}`, atModelRate(clip),
                           await skeletonOfReply(encoded), encoded);
}

// A file of the server's data root: the server reads its window (the
// model's 25 Hz, as it takes an upload), which is sent back to be encoded.
async function reconstructClip(view) {
  const path = $('clip-path').value;
  if (!path) throw new Error("choose a file of the server's data root first (Refresh lists them)");
  const clip = await callWithToken('GET', clipWindowPath(path, Number($('clip-start').value)));
  showClipBounds(clip);
  const encoded = await callApi('POST', 'v1/encode', { body: { motions: [clip.motion] }, summary: path });
  await showReconstruction(view, `${clip.path} @${clip.start}`, clip.motion, await skeletonOfReply(encoded), encoded);
}

async function sample(view) {
  const seed = $('sample-seed').value;
  const reply = await callApi('POST', 'v1/sample', {
    body: { count: Number($('sample-count').value), seed, decoder: decoder() } });
  const skeleton = await skeletonOfReply(reply);
  const figures = reply.motions.map((motion, i) => {
    const name = `sample ${i + 1} (seed ${seed})`;
    shelve(name, motion, skeleton, reply.codes[i]);
    return figure(name, motion, skeleton);
  });
  view.show(figures);
  say(`${reply.motions.length} samples; ${answeredBy(reply)}`);
}

async function interpolate(view) {
  const from = shelfEntry($('interpolate-from').value), to = shelfEntry($('interpolate-to').value);
  if (!from || !to) throw new Error('interpolation needs two motions: sample or upload some first');
  const method = $('interpolate-method').value;
  const reply = await callApi('POST', 'v1/interpolate', {
    body: { from: operand(from), to: operand(to), steps: Number($('interpolate-steps').value), method, decoder: decoder() } });
  const skeleton = await skeletonOfReply(reply);
  const steps = reply.motions.map((motion) => figure('', motion, skeleton));
  const slider = $('interpolate-slider');
  slider.max = String(steps.length - 1);
  slider.value = String(Math.floor((steps.length - 1) / 2));
  const stepLabel = () => `${method} step ${Number(slider.value) + 1} of ${steps.length}`;
  view.show([entryFigure(from.name, from), { ...steps[Number(slider.value)], label: stepLabel() }, entryFigure(to.name, to)]);
  slider.disabled = false;
  slider.oninput = () => {
    const step = steps[Number(slider.value)];
    view.replacePositions(1, step.positions, stepLabel(), step.rootPath);
  };
  reply.motions.forEach((motion, i) => shelve(`${from.name} → ${to.name} ${method} ${i + 1}/${steps.length}`, motion, skeleton,
                                              reply.codes[i]));
  say(`${steps.length} steps; move the slider to walk along the path; ${answeredBy(reply)}`);
}

async function analogy(view) {
  const [a, b, c] = ['a', 'b', 'c'].map((k) => shelfEntry($(`analogy-${k}`).value));
  if (!a || !b || !c) throw new Error('analogy needs three motions: sample or upload some first');
  const reply = await callApi('POST', 'v1/analogy', { body: { a: operand(a), b: operand(b), c: operand(c), decoder: decoder() } });
  const name = `${a.name} − ${b.name} + ${c.name}`;
  const skeleton = await skeletonOfReply(reply);
  shelve(name, reply.motions[0], skeleton, reply.codes[0]);
  view.show([entryFigure(`a: ${a.name}`, a), entryFigure(`b: ${b.name}`, b), entryFigure(`c: ${c.name}`, c),
             figure('a − b + c', reply.motions[0], skeleton)]);
  say(`analogy; ${answeredBy(reply)}`);
}

// Sec. 5.4: corrupt, then project onto the manifold (the decoded motion) and
// fill (the observed values kept, the missing ones from the manifold).
async function denoise(view) {
  const source = shelfEntry($('denoise-source').value);
  if (!source) throw new Error('denoising needs a motion: sample or upload one first');
  const probability = Number($('denoise-probability').value);
  const corrupted = corruptZeroed(source.motion, probability, Number($('denoise-seed').value));
  const request = { motions: [corrupted], decoder: decoder(), zeros_are_missing: true };
  const projected = (await callApi('POST', 'v1/denoise', { body: request, summary: 'projected' })).motions[0];
  const filled = (await callApi('POST', 'v1/denoise', { body: { ...request, keep_observed: true }, summary: 'filled' })).motions[0];
  const { skeleton } = source;  // the server refuses a motion of another rig than its model's
  const truth = motionPositions(source.motion, skeleton);
  const error = (motion) => meanJointErrorMm(truth, motionPositions(motion, skeleton)).toFixed(1);
  view.show([entryFigure(source.name, source), figure(`corrupted (${error(corrupted)} mm)`, corrupted, skeleton),
             figure(`projected (${error(projected)} mm)`, projected, skeleton),
             figure(`filled (${error(filled)} mm)`, filled, skeleton)]);
  shelve(`${source.name} denoised`, projected, skeleton);
  say(`values dropped with probability ${probability} (set to zero, the paper's corruption); errors against the original`);
}

// Two shelf motions joined by a transition (the motions themselves: the
// server joins frames, not codes); the joined motion plays between them.
async function join(view) {
  const a = shelfEntry($('join-a').value), b = shelfEntry($('join-b').value);
  if (!a || !b) throw new Error('joining needs two motions: sample or upload some first');
  const method = $('join-method').value;
  const reply = await callApi('POST', 'v1/join', {
    body: { a: a.motion, b: b.motion, transition_seconds: Number($('join-seconds').value), method, decoder: decoder() } });
  const skeleton = await skeletonOfReply(reply);
  const first = reply.transition_first_frame, last = reply.transition_last_frame;
  const name = `${a.name} + ${b.name} (${method})`;
  shelve(name, reply.motion, skeleton);
  view.show([entryFigure(`a: ${a.name}`, a), figure(`joined, ${method} frames ${first}–${last}`, reply.motion, skeleton),
             entryFigure(`b: ${b.name}`, b)]);
  say(`${reply.motion.frames} frames at 25 Hz, the ${method} transition at ${(first / 25).toFixed(2)}–` +
      `${((last + 1) / 25).toFixed(2)} s; ${answeredBy(reply)}`);
}

export function setUpManifoldPanel(view) {
  ['interpolate-to', 'analogy-b', 'denoise-source', 'join-b'].forEach((id) => bindMenu($(id), 0));
  ['interpolate-from', 'analogy-a', 'join-a'].forEach((id) => bindMenu($(id), 1));
  bindMenu($('analogy-c'), 2);
  const actions = { 'upload-button': reconstructUpload, 'clip-button': reconstructClip, 'sample-button': sample,
                    'interpolate-button': interpolate, 'analogy-button': analogy, 'denoise-button': denoise,
                    'join-button': join };
  for (const [id, action] of Object.entries(actions)) $(id).addEventListener('click', () => runAction(() => action(view)));
}
