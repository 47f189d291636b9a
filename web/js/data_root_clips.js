// The motion files of the server's data root (GET v1/clips) in a menu, and
// the window start bounded by the chosen file's length: a window read
// (GET v1/clips/window) answers the file's frame count, rate and the last
// start that still gives a full window. The data root is the operator's:
// reading it takes the token unless the server was started with --public-clips.
// The files that were uploaded are listed apart, each with a delete button
// (DELETE v1/clips?path=; the rest of the data root cannot be deleted).
import { callWithToken } from './api_client.js';
import { runAction } from './call_log.js';

const $ = (id) => document.getElementById(id);

// The REST path of a file's window from `start` (the file's own frames).
export function clipWindowPath(path, start) {
  return `v1/clips/window?path=${encodeURIComponent(path)}&start=${start}`;
}

// Bounds the start input by a window reply and says what the file holds.
export function showClipBounds(clip) {
  const start = $('clip-start');
  start.max = String(clip.last_start);
  if (Number(start.value) > clip.last_start) start.value = String(clip.last_start);
  $('clip-info').textContent = `${clip.path}: ${clip.file_frames} frames at ${clip.file_frame_rate} Hz; ` +
                               `window start 0 to ${clip.last_start}`;
}

// Fills the menu with the data root's files (again after an upload).
export async function listClips() {
  const { clips, truncated } = await callWithToken('GET', 'v1/clips');
  const menu = $('clip-path');
  const chosen = menu.value;
  menu.replaceChildren(...clips.map((clip) =>
    new Option(`${clip.path} (${clip.format}, ${Math.ceil(clip.size_bytes / 1024)} KiB)`, clip.path)));
  if (clips.some((clip) => clip.path === chosen)) menu.value = chosen;
  showUploads(clips.filter((clip) => clip.uploaded));
  $('clip-info').textContent = clips.length
    ? `${clips.length} files${truncated ? ', the first the server lists' : ''}: choose one for its length`
    : "no .txt or .bvh file under the server's data root";
}

function showUploads(uploads) {
  const table = $('uploads');
  table.replaceChildren();
  for (const clip of uploads) {
    const row = table.insertRow();
    row.dataset.path = clip.path;
    row.insertCell().textContent = `uploaded: ${clip.path} (${Math.ceil(clip.size_bytes / 1024)} KiB)`;
    const remove = document.createElement('button');
    remove.className = 'delete';
    remove.textContent = 'Delete';
    remove.addEventListener('click', () => runAction(async () => {
      await callWithToken('DELETE', `v1/clips?path=${encodeURIComponent(clip.path)}`, { summary: clip.path });
      await listClips();
    }));
    row.insertCell().append(remove);
  }
}

// The chosen file's length, read as its first window.
async function describeChosenClip() {
  const path = $('clip-path').value;
  if (path) showClipBounds(await callWithToken('GET', clipWindowPath(path, 0), { summary: "the file's length" }));
}

export function setUpClipPicker() {
  $('clips-refresh').addEventListener('click', () => runAction(listClips));
  $('clip-path').addEventListener('change', () => runAction(describeChosenClip));
  return runAction(listClips);
}
