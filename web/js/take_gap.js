// A gap marked on a take: a span of time (seconds on the page, read as the
// take's frames) and the joints missing in it, every joint or a chosen set
// of the model's skeleton. The take goes to the server as motion text with
// those joints' values `nan` over the gap (the root translation is never
// missing: server/rest/README.md, "Takes"), to be filled by POST
// v1/takes:denoise?keep_observed=true, which keeps every other value as it
// came. A take that arrives with values missing already (NaN in a file's
// text, or in a data-root file read whole) has its own gaps: the spans
// missingSpans finds, filled the same way as it loads. The form's fields
// are read here; the take panel sends and draws.

const $ = (id) => document.getElementById(id);

// Filled frames are drawn in this colour (the view's skeleton, the strip's
// and the plot's shading): none of the view's figure colours.
export const GAP_COLOUR = '#d35cff';

// The fill methods of the denoise route's gap_fill, the service's default
// first (sent without the parameter, so that the page works with a server
// that predates it).
export const GAP_FILL_METHODS = ['borrowed', 'fitted', 'matched', 'cubic', 'slerp', 'hold', 'manifold'];
export const DEFAULT_GAP_FILL = GAP_FILL_METHODS[0];

// The frames f of a take of `frames` frames at `rate` Hz whose time f/rate
// lies from `fromSeconds` to `toSeconds` (both included), as { first, last };
// an error naming the field for a span that holds no frame of the take.
export function gapFrames(fromSeconds, toSeconds, frames, rate) {
  const duration = (frames - 1) / rate;
  if (!Number.isFinite(fromSeconds) || fromSeconds < 0 || fromSeconds > duration) {
    throw new Error(`gap from: ${fromSeconds} s; expected a time from 0 to the take's end, ${duration.toFixed(2)} s`);
  }
  if (!Number.isFinite(toSeconds) || toSeconds < fromSeconds) {
    throw new Error(`gap to: ${toSeconds} s; expected a time from the gap's start, ${fromSeconds} s, on`);
  }
  // A millionth of a frame of slack, so that 5 s at 50 Hz is frame 250.
  const first = Math.ceil(fromSeconds * rate - 1e-6);
  const last = Math.min(frames - 1, Math.floor(toSeconds * rate + 1e-6));
  if (last < first) {
    throw new Error(`gap ${fromSeconds} to ${toSeconds} s holds no frame of the take at ${rate} Hz; expected a longer span`);
  }
  return { first, last };
}

// The columns of joint `j` of a motion: 3 + 3j .. 3 + 3j + 2 (columns 0..2
// are the root translation; model_skeletons.js).
function jointColumns(j) {
  return [3 + 3 * j, 4 + 3 * j, 5 + 3 * j];
}

// `motion` (a wire motion of the take) as motion text, the values of the
// gap's columns `nan` on its frames; every value otherwise written as
// JavaScript's shortest form of the number read, so it reads back the same.
export function motionTextWithGap(motion, { first, last, columns }) {
  const missing = new Set(columns);
  const lines = [];
  for (let f = 0; f < motion.frames; ++f) {
    const row = motion.values.slice(f * motion.columns, (f + 1) * motion.columns);
    const inGap = f >= first && f <= last;
    lines.push(row.map((v, c) => (inGap && missing.has(c) ? 'nan' : String(v))).join(','));
  }
  return `${lines.join('\n')}\n`;
}

// The take's own gaps: the spans of frames of `motion` (a wire motion) in
// which some joint value is missing (NaN, as a take's text marks it and
// the whole read carries it), as [{ first, last }], and the joints missing
// somewhere in them (indices into the skeleton's joints); no spans for a
// take with nothing missing.
export function missingSpans(motion) {
  const spans = [];
  const joints = new Set();
  for (let f = 0; f < motion.frames; ++f) {
    let missing = false;
    for (let c = 3; c < motion.columns; ++c) {
      if (Number.isNaN(motion.values[f * motion.columns + c])) {
        missing = true;
        joints.add(Math.floor((c - 3) / 3));
      }
    }
    if (!missing) continue;
    const last = spans[spans.length - 1];
    if (last && last.last === f - 1) last.last = f;
    else spans.push({ first: f, last: f });
  }
  return { spans, joints: [...joints].sort((a, b) => a - b) };
}

// The gap shown for a take's own missing values (missingSpans) filled by
// `method`: as markedGap's, with every span and `own` set.
export function ownGap({ spans, joints }, skeleton, method) {
  return {
    first: spans[0].first,
    last: spans[spans.length - 1].last,
    spans,
    columns: joints.flatMap(jointColumns),
    joints: joints.length === skeleton.jointNames.length ? 'every joint' : joints.map((j) => skeleton.jointNames[j]).join(', '),
    method,
    own: true,
  };
}

// The fill method the form has chosen.
export function chosenGapFill() {
  return $('gap-method').value;
}

// Fills the joint menu with `skeleton`'s joint names (when it is another
// skeleton than the one listed), keeping what was chosen of the same one.
export function listGapJoints(skeleton) {
  const menu = $('gap-joints');
  if (menu.dataset.skeleton === skeleton.name && menu.options.length === skeleton.jointNames.length) return;
  menu.replaceChildren(...skeleton.jointNames.map((name, j) => new Option(name, String(j))));
  menu.dataset.skeleton = skeleton.name;
}

// The gap the form marks on a take of `frames` frames at `rate` Hz of
// `skeleton`: { first, last, columns, joints (their names, or 'every
// joint'), method }.
export function markedGap(frames, rate, skeleton) {
  const { first, last } = gapFrames(Number($('gap-from').value), Number($('gap-to').value), frames, rate);
  const every = $('gap-every-joint').checked;
  const chosen = every ? skeleton.jointNames.map((_, j) => j)
    : [...$('gap-joints').selectedOptions].map((option) => Number(option.value));
  if (chosen.length === 0) throw new Error('gap joints: none chosen; expected "every joint" or one or more joints of the list');
  return {
    first,
    last,
    columns: chosen.flatMap(jointColumns),
    joints: every ? 'every joint' : chosen.map((j) => skeleton.jointNames[j]).join(', '),
    method: chosenGapFill(),
  };
}

// The form's wiring: the joint list only when "every joint" is off, and the
// frames the times stand for under them.
export function setUpGapForm(describeTake) {
  $('gap-method').replaceChildren(...GAP_FILL_METHODS.map((method) =>
    new Option(method === DEFAULT_GAP_FILL ? `${method} (the service's default)` : method, method)));
  const showFrames = () => {
    $('gap-joints').disabled = $('gap-every-joint').checked;
    const take = describeTake();
    if (!take) {
      // No take to mark (none yet, or one whose frames the page does not hold).
      $('gap-frames').textContent = 'reconstruct a take first: the gap is marked on its frames';
      return;
    }
    try {
      const { first, last } = gapFrames(Number($('gap-from').value), Number($('gap-to').value), take.frames, take.rate);
      $('gap-frames').textContent = `frames ${first} to ${last} of ${take.frames} (${last - first + 1} frames at ${take.rate} Hz)`;
    } catch (error) {
      $('gap-frames').textContent = error.message;
    }
  };
  for (const id of ['gap-from', 'gap-to', 'gap-every-joint']) $(id).addEventListener('input', showFrames);
  return showFrames;
}
