// The motions the page holds (uploads, samples, reconstructions, results),
// each a 25 Hz wire motion with the skeleton it is drawn with and its code
// when known, and the menus that pick one of them as an operation's input.
const entries = [];
const listeners = [];

// Adds a motion of `skeleton` (model_skeletons.js); returns its entry.
// `code` is the 64 floats it decodes from, if known.
export function shelve(name, motion, skeleton, code) {
  const entry = { id: entries.length, name, motion, skeleton, code };
  entries.push(entry);
  listeners.forEach((refresh) => refresh());
  return entry;
}

export function shelfEntry(id) {
  return entries[Number(id)];
}

// The operand of Interpolate and Analogy: the code when the page has it
// (smaller to send), else the motion.
export function operand(entry) {
  return entry.code ? { code: entry.code } : { motion: entry.motion };
}

// Keeps <select> `menu` listing the shelf, newest first. Until the user
// picks one, it follows the newest motions: the entry
// `preferredIndexFromNewest` places from the newest (so that "from" and
// "to" start on two different motions).
export function bindMenu(menu, preferredIndexFromNewest = 0) {
  menu.addEventListener('change', () => (menu.dataset.chosen = 'true'));
  const refresh = () => {
    const chosen = menu.value;
    menu.replaceChildren(...entries.slice().reverse().map((entry) => new Option(entry.name, String(entry.id))));
    if (menu.dataset.chosen && entries[Number(chosen)]) menu.value = chosen;
    else if (entries.length) menu.value = String(Math.max(0, entries.length - 1 - preferredIndexFromNewest));
  };
  listeners.push(refresh);
  refresh();
}
