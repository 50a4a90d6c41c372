// The 1D transfer-function editor: the model's value histogram (linear or log counts), the
// opacity control points (drag to move, click to add, double-click to remove) and the colour
// map as a strip beneath. The TF travels as ParaView JSON (SPEC §7).
const PAD = {left: 8, right: 8, top: 8, bottom: 26};
const HIT = 7;  // pixels: how near a point a press grabs it

export function parseParaViewTf(text) {
  let data = JSON.parse(text);
  if (Array.isArray(data)) data = data[0];
  if (!data || !Array.isArray(data.RGBPoints) || !Array.isArray(data.Points))
    throw new Error('a ParaView TF needs "RGBPoints" and "Points" arrays');
  const groups = (flat, what) => {
    if (flat.length === 0 || flat.length % 4 !== 0 || flat.some((v) => typeof v !== 'number'))
      throw new Error(`"${what}" must hold numbers in groups of 4`);
    const out = [];
    for (let i = 0; i < flat.length; i += 4) out.push(flat.slice(i, i + 4));
    return out;
  };
  return {rgb: groups(data.RGBPoints, 'RGBPoints'), points: groups(data.Points, 'Points')};
}

export function toParaViewJson(tf, name = 'udvr serve') {
  return JSON.stringify([{
    Name: name, ColorSpace: 'RGB',
    RGBPoints: tf.rgb.flat(), Points: tf.points.flat(),
  }], null, 1);
}

// Colour of the TF at x (piecewise linear, clamped), as SPEC §4.
export function colourAt(rgb, x) {
  if (x <= rgb[0][0]) return rgb[0].slice(1);
  for (let i = 1; i < rgb.length; ++i) {
    if (x < rgb[i][0]) {
      const [x0, ...c0] = rgb[i - 1], [x1, ...c1] = rgb[i];
      const t = x1 > x0 ? (x - x0) / (x1 - x0) : 1;
      return c0.map((c, k) => c + t * (c1[k] - c));
    }
  }
  return rgb[rgb.length - 1].slice(1);
}

// Opacity of the TF at x (piecewise linear between its points, clamped).
export function opacityAt(points, x) {
  return colourAt(points.map(([px, a]) => [px, a]), x)[0];
}

export class TfEditor {
  constructor(canvas, onChange) {
    this.canvas = canvas;
    this.onChange = onChange;  // onChange('drag' | 'commit')
    this.tf = {rgb: [[0, 0, 0, 0], [1, 1, 1, 1]], points: [[0, 0, 0.5, 0], [1, 1, 0.5, 0]]};
    this.histogram = null;
    this.log = false;
    this.dragging = -1;
    canvas.addEventListener('mousedown', (e) => this.press(e));
    window.addEventListener('mousemove', (e) => this.move(e));
    window.addEventListener('mouseup', () => this.release());
    canvas.addEventListener('dblclick', (e) => this.remove(e));
  }

  setTf(tf) {
    this.tf = {rgb: tf.rgb.map((p) => p.slice()), points: tf.points.map((p) => p.slice())};
    this.draw();
  }

  setHistogram(h) {
    this.histogram = h;
    this.draw();
  }

  // The value range the editor spans: the histogram's, widened to every control point.
  domain() {
    const xs = [...this.tf.rgb.map((p) => p[0]), ...this.tf.points.map((p) => p[0])];
    let lo = Math.min(...xs), hi = Math.max(...xs);
    if (this.histogram) lo = Math.min(lo, this.histogram.lo), hi = Math.max(hi, this.histogram.hi);
    if (!(hi > lo)) hi = lo + 1;
    return [lo, hi];
  }

  plotBox() {
    const w = this.canvas.width, h = this.canvas.height;
    return {x: PAD.left, y: PAD.top, w: w - PAD.left - PAD.right, h: h - PAD.top - PAD.bottom};
  }

  toPixel(x, a) {
    const [lo, hi] = this.domain(), b = this.plotBox();
    return [b.x + (x - lo) / (hi - lo) * b.w, b.y + (1 - a) * b.h];
  }

  fromPixel(px, py) {
    const [lo, hi] = this.domain(), b = this.plotBox();
    const x = lo + (px - b.x) / b.w * (hi - lo);
    const a = Math.min(1, Math.max(0, 1 - (py - b.y) / b.h));
    return [x, a];
  }

  eventPixel(e) {
    const r = this.canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * this.canvas.width / r.width,
            (e.clientY - r.top) * this.canvas.height / r.height];
  }

  nearest(px, py) {
    let best = -1, bestD = HIT;
    this.tf.points.forEach(([x, a], i) => {
      const [qx, qy] = this.toPixel(x, a);
      const d = Math.hypot(qx - px, qy - py);
      if (d <= bestD) best = i, bestD = d;
    });
    return best;
  }

  press(e) {
    if (e.button !== 0) return;
    const [px, py] = this.eventPixel(e);
    let i = this.nearest(px, py);
    if (i < 0) {
      const b = this.plotBox();
      if (px < b.x || px > b.x + b.w || py < b.y || py > b.y + b.h) return;
      const [x, a] = this.fromPixel(px, py);
      i = this.tf.points.findIndex((p) => p[0] > x);
      if (i < 0) i = this.tf.points.length;
      this.tf.points.splice(i, 0, [x, a, 0.5, 0]);
      this.onChange('drag');
    }
    this.dragging = i;
    this.draw();
    e.preventDefault();
  }

  move(e) {
    if (this.dragging < 0) return;
    const [px, py] = this.eventPixel(e);
    this.dragTo(this.dragging, ...this.fromPixel(px, py));
  }

  // Move point i to (x, a): x kept between its neighbours, so the points stay ascending.
  dragTo(i, x, a) {
    const pts = this.tf.points;
    const lo = i > 0 ? pts[i - 1][0] : -Infinity, hi = i + 1 < pts.length ? pts[i + 1][0] : Infinity;
    pts[i][0] = Math.min(hi, Math.max(lo, x));
    pts[i][1] = Math.min(1, Math.max(0, a));
    this.draw();
    this.onChange('drag');
  }

  release() {
    if (this.dragging < 0) return;
    this.dragging = -1;
    this.draw();
    this.onChange('commit');
  }

  remove(e) {
    const i = this.nearest(...this.eventPixel(e));
    if (i < 0 || this.tf.points.length <= 2) return;
    this.tf.points.splice(i, 1);
    this.draw();
    this.onChange('commit');
  }

  draw() {
    const ctx = this.canvas.getContext('2d'), b = this.plotBox();
    const [lo, hi] = this.domain();
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    ctx.fillStyle = '#fafafa';
    ctx.fillRect(b.x, b.y, b.w, b.h);
    const h = this.histogram;
    if (h) {
      const height = (c) => (this.log ? Math.log10(1 + c) : c);
      const top = Math.max(...h.counts.map(height)) || 1;
      const bw = (h.hi - h.lo) / h.counts.length;
      ctx.fillStyle = '#c8c8d0';
      h.counts.forEach((c, k) => {
        const [x0] = this.toPixel(h.lo + k * bw, 0), [x1] = this.toPixel(h.lo + (k + 1) * bw, 0);
        const bh = height(c) / top * b.h;
        ctx.fillRect(x0, b.y + b.h - bh, Math.max(1, x1 - x0), bh);
      });
    }
    // Colour strip.
    for (let px = 0; px < b.w; ++px) {
      const c = colourAt(this.tf.rgb, lo + (px + 0.5) / b.w * (hi - lo));
      ctx.fillStyle = `rgb(${c.map((v) => Math.round(255 * v)).join(',')})`;
      ctx.fillRect(b.x + px, b.y + b.h + 6, 1, 14);
    }
    // Opacity curve and its points.
    ctx.strokeStyle = '#222';
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    const pts = this.tf.points;
    const first = this.toPixel(lo, pts[0][1]);
    ctx.moveTo(...first);
    pts.forEach(([x, a]) => ctx.lineTo(...this.toPixel(x, a)));
    ctx.lineTo(...this.toPixel(hi, pts[pts.length - 1][1]));
    ctx.stroke();
    pts.forEach(([x, a], i) => {
      const [qx, qy] = this.toPixel(x, a);
      ctx.beginPath();
      ctx.arc(qx, qy, 4.5, 0, 2 * Math.PI);
      ctx.fillStyle = i === this.dragging ? '#e34a33' : '#fff';
      ctx.fill();
      ctx.stroke();
    });
    ctx.fillStyle = '#555';
    ctx.font = '11px sans-serif';
    ctx.textBaseline = 'top';
    ctx.fillText(lo.toPrecision(4), b.x + 2, b.y + 2);
    const hiText = hi.toPrecision(4);
    ctx.fillText(hiText, b.x + b.w - 2 - ctx.measureText(hiText).width, b.y + 2);
  }
}
