// The distribution at a probed point, as the paper's Fig. 2: each plotted model's density at the
// point (its point masses as spikes), over the TF's opacity (with a 2D TF: its opacity along x
// at one y, which the caller chooses and labels). Which models are plotted (`plot` of
// /api/state's models: each 1D kernel type's first row) and each curve (`plot` of /api/probe's
// JSON: that of `udvr probe --json`, the same object `udvr probe --plot` draws) come from the
// server, so no model is named here.

// The curves' colours, in the order of the plotted models.
const PALETTE = ['#8c510a', '#2166ac', '#b2182b', '#1b7837', '#762a83', '#e08214', '#4d4d4d'];

// The models to plot ({name, colour, label}) from /api/state's models.
export function plotModels(models) {
  return models.filter((m) => m.plot)
      .map((m, k) => ({name: m.name, colour: PALETTE[k % PALETTE.length], label: m.name}));
}

// Density of the distribution described by probe JSON `j` at x: its continuous part's bin
// averages over [lo, hi], 0 outside (null where it has none: point masses only).
export function densityOf(j) {
  const {lo, hi, density} = j.plot;
  if (density.length === 0) return null;
  const n = density.length;
  return (x) => (x >= lo && x <= hi ? density[Math.min(n - 1, Math.floor((x - lo) / (hi - lo) * n))] : 0);
}

const rangeOf = (j) => [j.plot.lo, j.plot.hi];

export const PLOT_STEPS = 400;  // the curves' x steps over the plot's range

// The plot's x range [lo, hi] for `probes` ({name: json}) of the models `plotted`
// (plotModels): every model's, padded; null for none.
export function plotRange(probes, plotted) {
  const names = plotted.filter((m) => probes[m.name]);
  if (names.length === 0) return null;
  let lo = Infinity, hi = -Infinity;
  for (const m of names) {
    const [a, b] = rangeOf(probes[m.name]);
    lo = Math.min(lo, a), hi = Math.max(hi, b);
  }
  if (!(hi > lo)) lo -= 0.5, hi += 0.5;
  const pad = 0.05 * (hi - lo);
  return [lo - pad, hi + pad];
}

// Draw `probes` ({name: json}) of the models `plotted` (plotModels) over the TF `beneath`:
// {alpha(x), colour(x) → [r, g, b], label} (label: what the dashed opacity is, or empty).
export function drawProbePlot(canvas, probes, plotted, beneath) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height;
  const box = {x: 36, y: 10, w: W - 46, h: H - 58};
  ctx.clearRect(0, 0, W, H);
  const range = plotRange(probes, plotted);
  if (!range) return;
  const [lo, hi] = range, N = PLOT_STEPS;
  const names = plotted.filter((m) => probes[m.name]);
  const xs = Array.from({length: N + 1}, (_, i) => lo + (hi - lo) * i / N);
  const curves = names.map((m) => {
    const f = densityOf(probes[m.name]);
    return {m, ys: f ? xs.map(f) : null, atoms: probes[m.name].plot.atoms};
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
  for (const {m, ys, atoms} of curves) {
    ctx.strokeStyle = m.colour;
    ctx.lineWidth = 1.6;
    // Point masses: spikes at their values, the largest mass the plot's full height.
    const heaviest = Math.max(0, ...atoms.map(([, mass]) => mass));
    for (const [x, mass] of atoms) {
      ctx.beginPath();
      ctx.moveTo(px(x), box.y + box.h);
      ctx.lineTo(px(x), box.y + box.h - mass / heaviest * box.h);
      ctx.stroke();
    }
    if (!ys) continue;
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
