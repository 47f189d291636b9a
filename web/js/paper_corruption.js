// The corruption of the denoising experiment as the paper states it
// (Sec. 5.4): every joint-angle value of every frame is dropped, set to
// zero, with a probability. The server then reads exact zeros as missing
// (zeros_are_missing). Seeded, so that a seed gives the same corruption.

// mulberry32: a small, well-mixed 32-bit generator; uniform in [0, 1).
function uniformGenerator(seed) {
  let state = seed >>> 0;
  return () => {
    state = (state + 0x6d2b79f5) >>> 0;
    let t = state;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// A copy of the 25 Hz wire motion with its rotation values (columns 3 on)
// zeroed with `probability`; the root translation is kept.
export function corruptZeroed(motion, probability, seed) {
  const uniform = uniformGenerator(seed);
  const values = motion.values.map((v, i) => (i % motion.columns >= 3 && uniform() < probability ? 0 : v));
  return { ...motion, values };
}
