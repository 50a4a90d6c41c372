// The distribution at a probed point, as the paper's Fig. 2: the quantile boundaries as a
// piecewise-constant PDF, the Gaussian, the GMM and the uniform, over the TF's opacity (with a
// 2D TF: its opacity along x at one y, which the caller chooses and labels). Each curve comes
// from the JSON of /api/probe (that of `udvr probe --json`) for its model.

export const PLOT_MODELS = [
  {name: 'quantile-range', colour: '#1b7837', label: 'quantiles'},
  {name: 'gaussian', colour: '#2166ac', label: 'Gaussian'},
  {name: 'gmm-ordered', colour: '#b2182b', label: 'GMM'},
  {name: 'uniform', colour: '#8c510a', label: 'uniform'},
];

const normal = (x, m, s) => Math.exp(-0.5 * ((x - m) / s) ** 2) / (s * Math.sqrt(2 * Math.PI));

// Density of the model described by probe JSON `j` at x (null where it has no density).
export function densityOf(name, j) {
  if (name === 'gaussian') return j.stddev > 0 ? (x) => normal(x, j.mean, j.stddev) : null;
  if (name === 'uniform') {
    const w = j.high - j.low;
    return w > 0 ? (x) => (x >= j.low && x <= j.high ? 1 / w : 0) : null;
  }
  if (name === 'gmm-ordered') {
    return (x) => j.weights.reduce(
        (s, w, k) => s + (j.sigmas[k] > 0 ? w * normal(x, j.means[k], j.sigmas[k]) : 0), 0);
  }
  if (name === 'quantile-range') {
    const b = j.boundaries, q = b.length - 1;
    const level = (k) => (j.levels ? j.levels[k] : k / q);
    return (x) => {
      for (let k = 1; k <= q; ++k)
        if (x >= b[k - 1] && x <= b[k] && b[k] > b[k - 1])
          return (level(k) - level(k - 1)) / (b[k] - b[k - 1]);
      return 0;
    };
  }
  return null;
}

function rangeOf(name, j) {
  if (name === 'gaussian') return [j.mean - 4 * j.stddev, j.mean + 4 * j.stddev];
  if (name === 'uniform') return [j.low, j.high];
  if (name === 'gmm-ordered')
    return [Math.min(...j.means.map((m, k) => m - 4 * j.sigmas[k])),
            Math.max(...j.means.map((m, k) => m + 4 * j.sigmas[k]))];
  if (name === 'quantile-range') return [j.boundaries[0], j.boundaries[j.boundaries.length - 1]];
  return [j.value, j.value];
}

export const PLOT_STEPS = 400;  // the curves' x steps over the plot's range

// The plot's x range [lo, hi] for `probes` ({name: json}): every model's, padded; null for none.
export function plotRange(probes) {
  const names = PLOT_MODELS.filter((m) => probes[m.name]);
  if (names.length === 0) return null;
  let lo = Infinity, hi = -Infinity;
  for (const m of names) {
    const [a, b] = rangeOf(m.name, probes[m.name]);
    lo = Math.min(lo, a), hi = Math.max(hi, b);
  }
  if (!(hi > lo)) lo -= 0.5, hi += 0.5;
  const pad = 0.05 * (hi - lo);
  return [lo - pad, hi + pad];
}

// Draw `probes` ({name: json}) over the TF `beneath`: {alpha(x), colour(x) → [r, g, b], label}
// (label: what the dashed opacity is, or empty).
export function drawProbePlot(canvas, probes, beneath) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height;
  const box = {x: 36, y: 10, w: W - 46, h: H - 58};
  ctx.clearRect(0, 0, W, H);
  const range = plotRange(probes);
  if (!range) return;
  const [lo, hi] = range, N = PLOT_STEPS;
  const names = PLOT_MODELS.filter((m) => probes[m.name]);
  const xs = Array.from({length: N + 1}, (_, i) => lo + (hi - lo) * i / N);
  const curves = names.map((m) => {
    const f = densityOf(m.name, probes[m.name]);
    return {m, ys: f ? xs.map(f) : null};
  });
  const top = Math.max(1e-300, ...curves.flatMap((c) => (c.ys ? c.ys : [])));
  const px = (x) => box.x + (x - lo) / (hi - lo) * box.w;
  const py = (y) => box.y + box.h - y / top * box.h;
  // The TF beneath: opacity (grey) and the colour strip.
  ctx.fillStyle = '#f4f4f4';
  ctx.fillRect(box.x, box.y, box.w, box.h);
  ctx.strokeStyle = '#999';
  ctx.setLineDash([4, 3]);
  ctx.beginPath();
  xs.forEach((x, i) => {
    const y = box.y + box.h - beneath.alpha(x) * box.h;
    i ? ctx.lineTo(px(x), y) : ctx.moveTo(px(x), y);
  });
  ctx.stroke();
  ctx.setLineDash([]);
  for (let i = 0; i < box.w; ++i) {
    const c = beneath.colour(lo + (i + 0.5) / box.w * (hi - lo));
    ctx.fillStyle = `rgb(${c.map((v) => Math.round(255 * v)).join(',')})`;
    ctx.fillRect(box.x + i, box.y + box.h + 4, 1, 8);
  }
  for (const {m, ys} of curves) {
    ctx.strokeStyle = m.colour;
    ctx.lineWidth = 1.6;
    if (!ys) {  // a point mass: a spike at the value
      const x = px(probes[m.name].value);
      ctx.beginPath();
      ctx.moveTo(x, box.y + box.h);
      ctx.lineTo(x, box.y);
      ctx.stroke();
      continue;
    }
    ctx.beginPath();
    ys.forEach((y, i) => (i ? ctx.lineTo(px(xs[i]), py(y)) : ctx.moveTo(px(xs[i]), py(y))));
    ctx.stroke();
  }
  ctx.fillStyle = '#333';
  ctx.font = '11px sans-serif';
  ctx.textBaseline = 'top';
  ctx.fillText(lo.toPrecision(4), box.x, box.y + box.h + 16);
  const hiText = hi.toPrecision(4);
  ctx.fillText(hiText, box.x + box.w - ctx.measureText(hiText).width, box.y + box.h + 16);
  if (beneath.label) {  // top right, over a veil so that the curves do not hide it
    const w = ctx.measureText(beneath.label).width, x = box.x + box.w - w - 4;
    ctx.fillStyle = 'rgba(244, 244, 244, 0.85)';
    ctx.fillRect(x - 3, box.y + 1, w + 6, 14);
    ctx.fillStyle = '#555';
    ctx.fillText(beneath.label, x, box.y + 2);
  }
  ctx.save();
  ctx.translate(12, box.y + box.h / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = 'center';
  ctx.fillText('density', 0, -6);
  ctx.restore();
  let lx = box.x;
  for (const {m} of curves) {
    ctx.fillStyle = m.colour;
    ctx.fillRect(lx, H - 14, 10, 3);
    ctx.fillStyle = '#333';
    ctx.fillText(m.label, lx + 13, H - 18);
    lx += 20 + ctx.measureText(m.label).width;
  }
}
