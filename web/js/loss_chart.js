// Loss curves of a training job drawn on a canvas as its progress events
// arrive: one line per loss term over iterations, on a logarithmic axis
// (the terms differ by orders of magnitude).
import { FIGURE_COLOURS } from './skeleton_view.js';

export class LossChart {
  constructor(canvas) {
    this.canvas = canvas;
    this.series = new Map();  // loss name -> [[iteration, value]]
  }

  // Records the losses of one progress report (a JobInfo's progress); draw() shows them.
  add(progress) {
    for (const [name, value] of Object.entries(progress.losses ?? {})) {
      if (!(value > 0)) continue;  // not drawable on a log axis
      if (!this.series.has(name)) this.series.set(name, []);
      const points = this.series.get(name);
      if (points.length && points[points.length - 1][0] === progress.iteration) continue;
      points.push([progress.iteration, value]);
    }
  }

  get pointCount() {
    return Math.max(0, ...[...this.series.values()].map((p) => p.length));
  }

  draw() {
    const { canvas } = this;
    const g = canvas.getContext('2d');
    const width = canvas.width, height = canvas.height, margin = 34;
    g.clearRect(0, 0, width, height);
    const all = [...this.series.values()].flat();
    if (!all.length) return;
    const [minX, maxX] = [Math.min(...all.map((p) => p[0])), Math.max(...all.map((p) => p[0]))];
    const logs = all.map((p) => Math.log10(p[1]));
    const [minY, maxY] = [Math.min(...logs), Math.max(...logs)];
    const x = (i) => margin + ((i - minX) / Math.max(1, maxX - minX)) * (width - 2 * margin);
    const y = (v) => height - margin - ((Math.log10(v) - minY) / Math.max(1e-9, maxY - minY)) * (height - 2 * margin);
    g.strokeStyle = '#556';
    g.strokeRect(margin, margin / 2, width - 2 * margin, height - 1.5 * margin);
    g.fillStyle = '#aab';
    g.font = '11px sans-serif';
    g.fillText(`iteration ${minX} – ${maxX}`, margin, height - 8);
    g.fillText(`log10 loss ${minY.toFixed(1)} – ${maxY.toFixed(1)}`, width - 170, height - 8);
    [...this.series.entries()].forEach(([name, points], k) => {
      const colour = FIGURE_COLOURS[k % FIGURE_COLOURS.length];
      g.strokeStyle = g.fillStyle = colour;
      g.beginPath();
      points.forEach(([i, v], n) => (n ? g.lineTo(x(i), y(v)) : g.moveTo(x(i), y(v))));
      g.stroke();
      g.fillText(name, margin + 4 + 70 * k, margin / 2 + 12);
    });
  }
}
