// A take: a whole recording of any length and rate, reconstructed by the
// server window by window (POST v1/takes:reconstruct, its JSON reply) and
// played over the original at the take's own rate, with its code track as a
// strip over time (a cell per window, coloured by the codes' first three
// principal components) and each frame's error plotted below; clicking the
// strip or the plot, or moving the view's slider, seeks both skeletons.
// "Download BVH" asks for the take shown once more, as a BVH file
// (Accept: application/x-bvh), and saves it. On a take loaded from a file
// or read whole from the server's data root, a gap marked by time and joints (take_gap.js) is filled by the server
// (POST v1/takes:denoise?keep_observed=true) and played beside the
// recording, its filled frames drawn in GAP_COLOUR and shaded on the strip
// and on the plot, which then shows each frame's distance from the recording.
// A take that has values missing already (NaN) is filled as it loads (the
// same route, the form's fill method) and drawn filled, its own gaps shaded;
// a gap marked later is marked on the filled take.
import { callApi, callWithToken } from './api_client.js';
import { runAction } from './call_log.js';
import { meanJointErrorMm, motionPositions } from './forward_kinematics.js';
import { skeletonOf } from './model_skeletons.js';
import { bvhToMotion, textTake } from './motion_files.js';
import { DEFAULT_GAP_FILL, GAP_COLOUR, chosenGapFill, listGapJoints, markedGap, missingSpans, motionTextWithGap, ownGap,
  setUpGapForm } from './take_gap.js';

const $ = (id) => document.getElementById(id);

// The first `count` principal directions of `rows` (power iteration with
// deflation on their covariance), each row's coordinates along them.
function principalCoordinates(rows, count) {
  const n = rows.length, d = rows[0].length;
  const mean = new Array(d).fill(0);
  rows.forEach((r) => r.forEach((v, i) => (mean[i] += v / n)));
  const centred = rows.map((r) => r.map((v, i) => v - mean[i]));
  const covariance = Array.from({ length: d }, () => new Array(d).fill(0));
  for (const r of centred) for (let i = 0; i < d; ++i) for (let j = 0; j < d; ++j) covariance[i][j] += r[i] * r[j];
  const coordinates = centred.map(() => []);
  for (let c = 0; c < count; ++c) {
    // A fixed start, so the same track is coloured the same way every time.
    let v = Array.from({ length: d }, (_, i) => 1 + ((i * 7919) % 13) / 13);
    for (let iteration = 0; iteration < 100; ++iteration) {
      const next = covariance.map((row) => row.reduce((sum, x, j) => sum + x * v[j], 0));
      const norm = Math.hypot(...next);
      if (norm < 1e-12) break;
      v = next.map((x) => x / norm);
    }
    const lambda = covariance.reduce((sum, row, i) => sum + v[i] * row.reduce((s, x, j) => s + x * v[j], 0), 0);
    for (let i = 0; i < d; ++i) for (let j = 0; j < d; ++j) covariance[i][j] -= lambda * v[i] * v[j];
    centred.forEach((r, k) => coordinates[k].push(r.reduce((sum, x, i) => sum + x * v[i], 0)));
  }
  return coordinates;
}

// One CSS colour per code: its first three principal coordinates, each
// scaled over the track to 0..255, as red, green and blue.
export function codeColours(codes) {
  if (codes.length < 2) return codes.map(() => 'rgb(128, 128, 128)');
  const coordinates = principalCoordinates(codes, 3);
  const ranges = [0, 1, 2].map((c) => {
    const values = coordinates.map((x) => x[c]);
    return [Math.min(...values), Math.max(...values)];
  });
  return coordinates.map((x) => {
    const [r, g, b] = ranges.map(([lo, hi], c) => Math.round(hi > lo ? (255 * (x[c] - lo)) / (hi - lo) : 128));
    return `rgb(${r}, ${g}, ${b})`;
  });
}

// The code track as a strip: cell i from window i's start to window i+1's
// (the last to the take's end), left to right over the take's duration; a
// filled gap (gapSpans: [{ first, last }] frames, none without one) shaded over it.
function drawStrip(strip, windows, frames, rate, view, spans) {
  const duration = Math.max((frames - 1) / rate, 1e-9);
  const colours = codeColours(windows.map((w) => w.code));
  strip.replaceChildren(...windows.map((w, i) => {
    const end = i + 1 < windows.length ? windows[i + 1].start_seconds : duration;
    const cell = document.createElement('div');
    cell.className = 'cell';
    cell.style.left = `${(100 * w.start_seconds) / duration}%`;
    cell.style.width = `${(100 * Math.max(0, end - w.start_seconds)) / duration}%`;
    cell.style.background = colours[i];
    cell.dataset.startFrame = String(w.start_frame);
    cell.title = `window ${i + 1} of ${windows.length}: ${w.start_seconds.toFixed(2)} s, frame ${w.start_frame}`;
    cell.addEventListener('click', () => view.seek(w.start_frame));
    return cell;
  }));
  for (const gap of spans) {
    const shade = document.createElement('div');
    shade.className = 'gap';
    shade.style.left = `${(100 * gap.first) / Math.max(frames - 1, 1)}%`;
    shade.style.width = `${(100 * Math.max(gap.last - gap.first, 1)) / Math.max(frames - 1, 1)}%`;
    // Hatched and outlined: a cell's code colour may be violet too.
    shade.style.background = `repeating-linear-gradient(135deg, ${GAP_COLOUR} 0 3px, transparent 3px 7px)`;
    shade.style.outline = `2px solid ${GAP_COLOUR}`;
    shade.title = `filled: frames ${gap.first} to ${gap.last}`;
    strip.append(shade);
  }
  const cursor = document.createElement('div');
  cursor.className = 'cursor';
  strip.append(cursor);
  return (frame) => (cursor.style.left = `${(100 * frame) / Math.max(frames - 1, 1)}%`);
}

// Each frame's error (mm) over the take, with a cursor at the frame shown
// and a filled gap's spans ([{ first, last }] frames) shaded; returns the
// function that moves the cursor.
function drawErrorPlot(canvas, errors, rate, view, spans) {
  const { width, height } = canvas;
  const margin = { left: 38, bottom: 16, top: 6 };
  const plotWidth = width - margin.left, plotHeight = height - margin.bottom - margin.top;
  const top = Math.max(...errors, 1e-6);
  const x = (frame) => margin.left + (plotWidth * frame) / Math.max(errors.length - 1, 1);
  const y = (error) => margin.top + plotHeight * (1 - error / top);
  const base = document.createElement('canvas');
  base.width = width;
  base.height = height;
  const g = base.getContext('2d');
  g.fillStyle = '#12151b';
  g.fillRect(0, 0, width, height);
  g.fillStyle = '#99a';
  g.font = '11px system-ui';
  g.fillText(`${top.toFixed(0)} mm`, 2, margin.top + 9);
  g.fillText('0', 2, margin.top + plotHeight);
  g.fillText(`${((errors.length - 1) / rate).toFixed(1)} s`, width - 40, height - 3);
  g.fillStyle = GAP_COLOUR;
  g.globalAlpha = 0.3;
  for (const gap of spans) g.fillRect(x(gap.first), margin.top, Math.max(x(gap.last) - x(gap.first), 1), plotHeight);
  g.globalAlpha = 1;
  g.strokeStyle = '#ff8a3d';
  g.beginPath();
  errors.forEach((error, frame) => (frame ? g.lineTo(x(frame), y(error)) : g.moveTo(x(frame), y(error))));
  g.stroke();
  canvas.dataset.frames = String(errors.length);
  const context = canvas.getContext('2d');
  const cursorAt = (frame) => {
    context.drawImage(base, 0, 0);
    context.strokeStyle = '#dde';
    context.beginPath();
    context.moveTo(x(frame), margin.top);
    context.lineTo(x(frame), margin.top + plotHeight);
    context.stroke();
  };
  cursorAt(0);
  canvas.onclick = (event) => {
    const fraction = (event.offsetX * (width / canvas.clientWidth) - margin.left) / plotWidth;
    view.seek(Math.round(Math.max(0, Math.min(1, fraction)) * (errors.length - 1)));
  };
  return cursorAt;
}

// What the take view shows, for the browser test; gap: the filled gap shown
// ({ first, last, columns, joints, method }, with spans and own for a take's
// own gaps: take_gap.js's ownGap), or null.
const shown = { frames: 0, frameRate: 0, windows: 0, errorFrames: 0, meanErrorMm: 0, gap: null };

// The take loaded from a file, which a gap can be marked on: { name, motion
// (a wire motion at the take's rate), skeleton }, or null (a data-root take,
// of which the page holds no copy).
let takeLoaded = null;
// The last filled take (the server's reply, kept for the browser test) and
// how many fills were shown.
const filled = { count: 0, reply: null };

// The take shown: its name, the call that reconstructs (or fills) it, given
// the reply's options (the same request with another Accept), and what the
// call made. Null until one is.
let takeShown = null;
// The last BVH downloaded (its text kept for the browser test).
const downloaded = { count: 0, fileName: '', bvh: '' };

// Draws a take's reply: the reconstruction over `original` (a wire motion
// at the reply's rate, or null when the page has no copy of the take), the
// strip and the error plot; or, given the `gap` it filled, the filled take
// beside the original, the gap marked, the plot each frame's distance (mm)
// from the original.
// A take's own gaps (gap.own) have no recording to compare: the filled take
// is drawn alone, the plot the reply's own per-frame error.
async function showTake(view, name, reply, original, gap = null) {
  const skeleton = await skeletonOf(reply.answered_by.model, reply.answered_by.version);
  const result = motionPositions({ frames: reply.frames, columns: reply.columns, values: reply.values }, skeleton);
  const compared = gap && !gap.own;
  const recording = original && !gap?.own && motionPositions(original, skeleton);
  const errors = compared ? result.map((pose, f) => meanJointErrorMm([pose], [recording[f]])) : reply.error_mm;
  const gapMeanMm = compared ? meanJointErrorMm(result.slice(gap.first, gap.last + 1), recording.slice(gap.first, gap.last + 1)) : 0;
  const spans = gap ? gap.spans ?? [{ first: gap.first, last: gap.last }] : [];
  const label = !gap ? `reconstruction (${reply.summary.mean_error_mm.toFixed(1)} mm)`
    : compared ? `${gap.method} fill (${gapMeanMm.toFixed(1)} mm from the recording in the gap)`
      : `${name}, its missing values filled by ${gap.method}`;
  const marked = gap && { first: gap.first, last: gap.last, spans: gap.spans, colour: GAP_COLOUR,
                          label: gap.own ? `filled: ${spanCount(spans)} (${gap.joints})`
                            : `filled frames ${gap.first} to ${gap.last} (${gap.joints})` };
  const figures = [{ label, positions: result, parents: skeleton.parents, frameRate: reply.frame_rate, marked }];
  if (recording) figures.unshift({ label: name, positions: recording, parents: skeleton.parents, frameRate: reply.frame_rate });
  const moveStripCursor = drawStrip($('take-strip'), reply.windows, reply.frames, reply.frame_rate, view, spans);
  const movePlotCursor = drawErrorPlot($('take-error'), errors, reply.frame_rate, view, spans);
  // The reconstruction over the original, on one spot; a fill beside the
  // recording, which it equals outside the gap.
  $('overlay').checked = !gap;
  view.show(figures);
  view.frameListeners.push((frame) => {
    moveStripCursor(frame);
    movePlotCursor(frame);
  });
  Object.assign(shown, { frames: reply.frames, frameRate: reply.frame_rate, windows: reply.windows.length,
                         errorFrames: errors.length, meanErrorMm: reply.summary.mean_error_mm, gap });
  const { summary } = reply;
  if (gap?.own) {
    $('take-info').textContent = `${name}: ${reply.frames} frames at ${reply.frame_rate} Hz, ${spanCount(spans)} with ` +
      `values missing (${gap.joints}) filled by ${gap.method}${fittedWork(summary)}; answered by ${reply.answered_by.model}`;
    $('result').textContent = 'the take\'s missing values filled: the filled frames are drawn and shaded in violet';
    return;
  }
  if (gap) {
    $('take-info').textContent = `${name}: frames ${gap.first} to ${gap.last} (${(gap.first / reply.frame_rate).toFixed(2)} ` +
      `to ${(gap.last / reply.frame_rate).toFixed(2)} s) of ${gap.joints} filled by ${gap.method}${fittedWork(summary)}, ` +
      `${gapMeanMm.toFixed(1)} mm from the recording there; ` +
      `the plot: each frame's distance from the recording, 0 outside the gap; answered by ${reply.answered_by.model}`;
    $('result').textContent = 'gap filled: the filled frames are drawn and shaded in violet, the recording beside them';
    return;
  }
  $('take-info').textContent = `${name}: ${reply.frames} frames at ${reply.frame_rate} Hz, ${reply.windows.length} ` +
    `windows of ${summary.window_seconds} s every ${summary.hop_seconds} s; error mean ${summary.mean_error_mm.toFixed(1)} ` +
    `mm, max ${summary.max_error_mm.toFixed(1)} mm; answered by ${reply.answered_by.model}`;
  $('result').textContent = `take reconstructed window by window: click the strip or the plot to seek`;
}

// "1 gap" or "3 gaps" of `spans`.
function spanCount(spans) {
  return `${spans.length} gap${spans.length === 1 ? '' : 's'}`;
}

// What the fitted fill did, from the reply's summary (its counts are 0 for
// the other methods): " (1 gap fitted in 1 window)", with the gaps left to
// the matched fill past the server's bound of windows a take (--max-take-gap-fits).
function fittedWork(summary) {
  const windows = summary.gap_windows_fitted ?? 0;
  const gaps = summary.gaps_fitted ?? 0;
  const over = summary.gaps_over_fit_limit ?? 0;
  if (windows === 0 && over === 0) return '';
  const plural = (n, word) => `${n} ${word}${n === 1 ? '' : 's'}`;
  const beyond = over > 0 ? `, ${plural(over, 'gap')} past the server's bound filled as matched` : '';
  return ` (${plural(gaps, 'gap')} fitted in ${plural(windows, 'window')}${beyond})`;
}

// Takes `takeShown` to a reconstructed take (or a filled one: `made` names
// what the server did in the file's name), with the download on.
function rememberTake(name, reconstruct, made = 'reconstructed') {
  takeShown = { name, reconstruct, made };
  for (const id of ['take-download-button', 'take-download-glb-button', 'take-download-gltf-button']) $(id).disabled = false;
}

// What the download buttons ask the server for: the take shown,
// reconstructed once more as a file of the model's skeleton.
const DOWNLOAD_FORMATS = {
  bvh: { type: 'application/x-bvh', name: 'BVH' },
  glb: { type: 'model/gltf-binary', name: 'glTF binary' },
  gltf: { type: 'model/gltf+json', name: 'glTF' },
};

// The take shown, reconstructed (or filled) by the server as `extension`
// (bvh, glb or gltf), saved as <name>-reconstructed.<extension> (or
// -<method>-filled; the name without its folders and extension).
async function downloadTake(extension) {
  if (!takeShown) throw new Error('reconstruct a take first');
  const { name, reconstruct, made } = takeShown;
  const format = DOWNLOAD_FORMATS[extension];
  const file = await reconstruct({ accept: format.type, summary: `${name} as ${format.name}` });
  const fileName = `${name.split('/').pop().replace(/\.[^.]*$/, '')}-${made}.${extension}`;
  const url = URL.createObjectURL(new Blob([file], { type: format.type }));
  const link = document.createElement('a');
  link.href = url;
  link.download = fileName;
  document.body.append(link);
  link.click();
  link.remove();
  // The download reads the URL after this click returns.
  setTimeout(() => URL.revokeObjectURL(url), 60000);
  const size = file.byteLength ?? file.length;
  Object.assign(downloaded, { count: downloaded.count + 1, fileName, bvh: extension === 'bvh' ? file : '',
                              bytes: size });
  $('result').textContent = `${fileName}: ${size} bytes`;
}

function takeQuery(extra) {
  const query = new URLSearchParams(extra);
  const hop = $('take-hop').value;
  if (hop) query.set('hop_seconds', hop);
  return query.toString();
}

// A file of the user's: sent as it is (text at the rate given, or BVH at
// its own), and read here too, to draw it under its reconstruction.
async function reconstructTakeFile(view) {
  const file = $('take-file').files[0];
  if (!file) throw new Error('choose a take first: exponential-map text or BVH of the model\'s skeleton');
  const extension = file.name.toLowerCase().split('.').pop();
  // glTF and FBX go as they are; the page draws the original of text and BVH.
  const animationType = { bvh: 'application/x-bvh', glb: 'model/gltf-binary', gltf: 'model/gltf+json',
                          fbx: 'application/octet-stream' }[extension];
  const isBvh = extension === 'bvh';
  const text = animationType && !isBvh ? null : await file.text();
  const rate = Number($('take-rate').value);
  const parsed = text !== null && !isBvh ? textTake(text, rate) : null;
  const own = parsed && missingSpans(parsed);
  if (own?.spans.length) {
    await fillOwnGaps(view, file.name, own, { frame_rate: rate },
                      (route, options) => callApi('POST', route, { body: text, contentType: 'text/plain', ...options }));
    return;
  }
  const route = `v1/takes:reconstruct?${takeQuery(animationType ? {} : { frame_rate: rate })}`;
  const reconstruct = (options) => callApi('POST', route, { body: text ?? file, contentType: animationType ?? 'text/plain',
                                                            summary: file.name, ...options });
  const reply = await reconstruct();
  const skeleton = await skeletonOf(reply.answered_by.model, reply.answered_by.version);
  const original = isBvh ? bvhToMotion(text, skeleton) : parsed;
  await showTake(view, file.name, reply, original);
  rememberTake(file.name, reconstruct);
  loadTake(original && { name: file.name, motion: { ...original, frame_rate: reply.frame_rate }, skeleton });
}

// Makes `take` (or null) the one a gap is marked on, the form's joints its skeleton's.
function loadTake(take) {
  takeLoaded = take;
  $('gap-button').disabled = !take;
  if (take) listGapJoints(take.skeleton);
  showGapFrames();
}

// A take with values missing already (`own`: missingSpans of it), filled as
// it loads by the route the form's gap fill names (POST
// v1/takes:denoise?keep_observed=true, `query` saying where the take is,
// `send` sending it), drawn filled with its gaps shaded, and loaded to mark
// a gap on as filled.
async function fillOwnGaps(view, name, own, query, send) {
  const method = chosenGapFill();
  const fillQuery = { ...query, keep_observed: 'true' };
  if (method !== DEFAULT_GAP_FILL) fillQuery.gap_fill = method;
  const route = `v1/takes:denoise?${takeQuery(fillQuery)}`;
  const fill = (options) => send(route, { summary: `${name}, its missing values (${method})`, ...options });
  const reply = await fill();
  const skeleton = await skeletonOf(reply.answered_by.model, reply.answered_by.version);
  await showTake(view, name, reply, null, ownGap(own, skeleton, method));
  rememberTake(name, fill, `${method}-filled`);
  Object.assign(filled, { count: filled.count + 1, reply });
  loadTake({ name, skeleton,
             motion: { frames: reply.frames, columns: reply.columns, frame_rate: reply.frame_rate, values: reply.values } });
}

// The gap the form marks on the loaded take, sent with those values `nan`
// to be filled by the method chosen (the default without gap_fill), and
// shown beside the recording; the download buttons then give the filled take.
async function fillTakeGap(view) {
  if (!takeLoaded) throw new Error('reconstruct a take first: the gap is marked on the page\'s copy of it');
  const { name, motion, skeleton } = takeLoaded;
  const gap = markedGap(motion.frames, motion.frame_rate, skeleton);
  const query = { frame_rate: motion.frame_rate, keep_observed: 'true' };
  if (gap.method !== DEFAULT_GAP_FILL) query.gap_fill = gap.method;
  const route = `v1/takes:denoise?${takeQuery(query)}`;
  const body = motionTextWithGap(motion, gap);
  const fill = (options) => callApi('POST', route, { body, contentType: 'text/plain',
                                                     summary: `${name}, gap ${gap.first} to ${gap.last} (${gap.method})`, ...options });
  const reply = await fill();
  await showTake(view, name, reply, motion, gap);
  rememberTake(name, fill, `${gap.method}-filled`);
  Object.assign(filled, { count: filled.count + 1, reply });
}

// A file of the server's data root (the menu of the first panel), read by
// the server itself (path=; the clip-read access), then read whole as a
// motion (GET v1/clips/motion, every frame at the file's rate in the model's
// layout) to draw it under its reconstruction and to mark a gap on, as a
// file's take is.
async function reconstructTakeClip(view) {
  const path = $('clip-path').value;
  if (!path) throw new Error("choose a file of the server's data root first (Refresh lists them)");
  const isText = path.toLowerCase().endsWith('.txt');
  const text = isText ? { frame_rate: $('take-rate').value } : {};
  // A text file is read whole first (its 99 columns whatever the model): one
  // with values missing is filled as it loads, which reconstructing it is not.
  let textWhole = null;
  if (isText) {
    textWhole = await readWhole(path, {});
    const own = textWhole && missingSpans(textWhole.motion);
    if (own?.spans.length) {
      await fillOwnGaps(view, path, own, { path, ...text }, (route, options) => callWithToken('POST', route, options));
      return;
    }
  }
  const route = `v1/takes:reconstruct?${takeQuery({ path, ...text })}`;
  const reconstruct = (options) => callWithToken('POST', route, { summary: path, ...options });
  const reply = await reconstruct();
  const { model, version } = reply.answered_by;
  const whole = isText ? textWhole : await readWhole(path, { model });
  // At the take's rate: a text file's rows at the rate it was sent at.
  const original = whole && { ...whole.motion, frame_rate: reply.frame_rate };
  await showTake(view, path, reply, original);
  rememberTake(path, reconstruct);
  loadTake(original && { name: path, motion: original, skeleton: await skeletonOf(model, version) });
}

// The data-root file `path` read whole (GET v1/clips/motion; `query` may
// name the model), its values' NaN spelt "NaN" made numbers; or null when
// it cannot be (a file too large to answer whole in one reply,
// --max-message-bytes: it is still shown reconstructed, with no gap to mark
// on it).
async function readWhole(path, query) {
  try {
    const whole = await callWithToken('GET', `v1/clips/motion?${new URLSearchParams({ path, ...query })}`,
                                      { summary: `${path}, whole` });
    whole.motion.values = whole.motion.values.map(Number);
    return whole;
  } catch (error) {
    console.warn(`${path} not read whole, so no gap can be marked on it: ${error.message}`);
    return null;
  }
}

// Writes the frames the gap's times stand for on the loaded take.
let showGapFrames = () => {};

export function setUpTakePanel(view) {
  window.motionManifoldPage.take = { describe: () => ({ ...shown, cells: $('take-strip').querySelectorAll('.cell').length }),
                                     downloaded: () => ({ ...downloaded }),
                                     filled: () => ({ ...filled }) };
  showGapFrames = setUpGapForm(() => takeLoaded && { frames: takeLoaded.motion.frames, rate: takeLoaded.motion.frame_rate });
  $('gap-button').addEventListener('click', () => runAction(() => fillTakeGap(view)));
  $('take-button').addEventListener('click', () => runAction(() => reconstructTakeFile(view)));
  $('take-clip-button').addEventListener('click', () => runAction(() => reconstructTakeClip(view)));
  $('take-download-button').addEventListener('click', () => runAction(() => downloadTake('bvh')));
  $('take-download-glb-button').addEventListener('click', () => runAction(() => downloadTake('glb')));
  $('take-download-gltf-button').addEventListener('click', () => runAction(() => downloadTake('gltf')));
}
