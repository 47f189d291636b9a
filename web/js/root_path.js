// The root's path through the world of a motion the server generated
// ("root": "generated", from a model with a root trajectory network), and
// the top-down inset that draws the paths of the motions shown.
//
// Such a motion is in world layout: each frame's columns 0..2 are the
// root's move since the previous frame in world axes (mm, y up, the floor
// at y = 0), frame 0's the root's start (0, height above the floor, 0), so
// the root stands at frame f at the running sum of frames 0..f. Any other
// motion ("input": an upload's or a denoised motion's root, whatever its
// source recorded; "none"; or no "root" member at all) has no path here:
// the H3.6M files hold moves in the root's own frame, which summed as world
// moves would draw a wrong path, so those stand at the origin as before.

// [x, y, z] (mm) of the root at every frame of `motion`, or null.
export function rootPath(motion) {
  if (motion.root !== 'generated') return null;
  const path = [];
  let x = 0, y = 0, z = 0;
  for (let f = 0; f < motion.frames; ++f) {
    const c = f * motion.columns;
    x += motion.values[c];
    y += motion.values[c + 1];
    z += motion.values[c + 2];
    path.push([x, y, z]);
  }
  return path;
}

// Paths closer together than this are still drawn at this span, so that a
// motion that hardly moves does not fill the inset with its jitter.
const SMALLEST_SPAN_MM = 2000;
const MARGIN_PX = 10;

// Draws `paths` on the 2D canvas as seen from above: x to the right and z
// down the canvas (a look down the -y axis), one scale for both so that
// turns keep their angles. Each path: { colour, points: [[x, y, z], ...],
// frame: the frame shown, at which a dot marks the root }.
export function drawRootInset(canvas, paths) {
  const g = canvas.getContext('2d');
  const { width, height } = canvas;
  g.clearRect(0, 0, width, height);
  const all = paths.flatMap((p) => p.points);
  if (!all.length) return;
  const xs = all.map((p) => p[0]), zs = all.map((p) => p[2]);
  const [minX, maxX, minZ, maxZ] = [Math.min(...xs), Math.max(...xs), Math.min(...zs), Math.max(...zs)];
  const span = Math.max(maxX - minX, maxZ - minZ, SMALLEST_SPAN_MM);
  const scale = (Math.min(width, height) - 2 * MARGIN_PX) / span;
  const centreX = (minX + maxX) / 2, centreZ = (minZ + maxZ) / 2;
  const at = (p) => [width / 2 + (p[0] - centreX) * scale, height / 2 + (p[2] - centreZ) * scale];
  for (const { colour, points, frame } of paths) {
    g.strokeStyle = colour;
    g.lineWidth = 1.5;
    g.beginPath();
    points.forEach((p, i) => (i ? g.lineTo(...at(p)) : g.moveTo(...at(p))));
    g.stroke();
    g.fillStyle = colour;
    g.beginPath();
    g.arc(...at(points[Math.min(frame, points.length - 1)]), 4, 0, 2 * Math.PI);
    g.fill();
  }
  g.fillStyle = '#99a';
  g.font = '10px system-ui';
  g.fillText(`top view, ${(span / 1000).toFixed(1)} m across`, 4, height - 4);
}
