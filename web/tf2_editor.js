// The 2D transfer-function editor (SPEC §9): the joint histogram of (value, gradient magnitude) —
// or (field 1, field 2) with --second — as grey counts (white empty, black the fullest bin, log or
// linear), and over it the widgets of docs/formats.md (box, triangle, ellipse with its rotation,
// band with its polyline points and half widths). The editor edits the widget JSON only: the
// server rasterises it with the library's parser (POST /api/tf2), exactly as `udvr render --tf2`
// reads the saved file.
const PAD = {left: 46, right: 10, top: 10, bottom: 34};
const HIT = 7;  // pixels: how near a handle a press grabs it
const ROTATE = 16;  // pixels: the rotation handle's distance beyond the ellipse's cutoff
const PALETTE = [[0.9, 0.3, 0.1], [0.15, 0.45, 0.95], [0.2, 0.7, 0.3], [0.95, 0.75, 0.1],
                 [0.6, 0.25, 0.75]];

// Numbers as they go into the JSON: 6 significant digits (the page's precision is a pixel).
const tidy = (v) => Number(v.toPrecision(6));

// Distance from point p to segment a–b (all [x, y] in the same units).
function segmentDistance([px, py], [ax, ay], [bx, by]) {
  const ex = bx - ax, ey = by - ay, len2 = ex * ex + ey * ey;
  const t = len2 > 0 ? Math.max(0, Math.min(1, ((px - ax) * ex + (py - ay) * ey) / len2)) : 0;
  return Math.hypot(px - ax - t * ex, py - ay - t * ey);
}

// Distance from p to a polyline (a lone point: to it).
function polylineDistance(p, pts) {
  let d = Infinity;
  for (let i = 0; i < pts.length; ++i)
    d = Math.min(d, segmentDistance(p, pts[i], pts[Math.min(i + 1, pts.length - 1)]));
  return d;
}

const cutoffOf = (w) => (w.cutoff === undefined ? 3 : w.cutoff);

export class Tf2Editor {
  constructor(canvas, onChange, onSelect) {
    this.canvas = canvas;
    this.onChange = onChange;  // onChange('drag' | 'commit')
    this.onSelect = onSelect;  // onSelect(widget or null): selected, or its shape dragged
    this.doc = {domain: [0, 1, 0, 1], widgets: []};
    this.histogram = null;
    this.histogramImage = null;
    this.log = true;
    this.selected = -1;
    this.drag = null;  // {index, handle, last: [x, y] in data units}
    this.editable = true;
    canvas.addEventListener('mousedown', (e) => this.press(e));
    window.addEventListener('mousemove', (e) => this.move(e));
    window.addEventListener('mouseup', () => this.release());
  }

  setDoc(doc) {
    this.doc = doc;
    if (this.selected >= doc.widgets.length) this.select(-1);
    this.draw();
  }

  // {bins: [nx, ny], domain, counts (row j = y bin, from the bottom), x, y}
  setHistogram(h) {
    this.histogram = h;
    this.histogramImage = null;
    this.draw();
  }

  setLog(log) {
    this.log = log;
    this.histogramImage = null;
    this.draw();
  }

  domain() { return this.doc.domain; }

  plotBox() {
    const w = this.canvas.width, h = this.canvas.height;
    return {x: PAD.left, y: PAD.top, w: w - PAD.left - PAD.right, h: h - PAD.top - PAD.bottom};
  }

  toPixel(x, y) {
    const [x0, x1, y0, y1] = this.domain(), b = this.plotBox();
    return [b.x + (x - x0) / (x1 - x0) * b.w, b.y + (1 - (y - y0) / (y1 - y0)) * b.h];
  }

  fromPixel(px, py) {
    const [x0, x1, y0, y1] = this.domain(), b = this.plotBox();
    return [x0 + (px - b.x) / b.w * (x1 - x0), y0 + (1 - (py - b.y) / b.h) * (y1 - y0)];
  }

  eventPixel(e) {
    const r = this.canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * this.canvas.width / r.width,
            (e.clientY - r.top) * this.canvas.height / r.height];
  }

  // Data point (x, y) in CSS pixels from the canvas's centre (for tests: where to press).
  cssOffset(x, y) {
    const [px, py] = this.toPixel(x, y);
    const r = this.canvas.getBoundingClientRect();
    return [(px - this.canvas.width / 2) * r.width / this.canvas.width,
            (py - this.canvas.height / 2) * r.height / this.canvas.height];
  }

  // A widget's centre, and one of its handles (by name), as cssOffset.
  centreOffset(index) { return this.cssOffset(...this.anchor(this.doc.widgets[index])); }
  handleOffset(index, name) {
    const [, x, y] = this.handles(this.doc.widgets[index]).find((h) => h[0] === name);
    return this.cssOffset(x, y);
  }

  // A point inside the widget, in data units.
  anchor(w) {
    switch (w.type) {
      case 'box': return [(w.x[0] + w.x[1]) / 2, (w.y[0] + w.y[1]) / 2];
      case 'triangle': return [w.apex[0], w.apex[1] + 0.7 * (w.top - w.apex[1])];
      case 'ellipse': return w.center.slice();
      case 'band': return w.points[0].slice();
    }
    return [0, 0];
  }

  // Ellipse axes in data units: u along sx (angle θ from +x), v along sy.
  static axes(w) {
    const t = (w.angle || 0) * Math.PI / 180;
    return [[Math.cos(t), Math.sin(t)], [-Math.sin(t), Math.cos(t)]];
  }

  // The widget's outline as polygons of data points (the band: its polyline).
  outline(w) {
    switch (w.type) {
      case 'box':
        return [[w.x[0], w.y[0]], [w.x[1], w.y[0]], [w.x[1], w.y[1]], [w.x[0], w.y[1]]];
      case 'triangle': {
        const h = w.width / 2;
        return [w.apex, [w.apex[0] - h, w.top], [w.apex[0] + h, w.top]];
      }
      case 'ellipse': {
        const [u, v] = Tf2Editor.axes(w), k = cutoffOf(w);
        const pts = [];
        for (let i = 0; i < 72; ++i) {
          const a = i / 72 * 2 * Math.PI, cu = k * w.sigma[0] * Math.cos(a), cv = k * w.sigma[1] * Math.sin(a);
          pts.push([w.center[0] + cu * u[0] + cv * v[0], w.center[1] + cu * u[1] + cv * v[1]]);
        }
        return pts;
      }
      case 'band': return w.points;
    }
    return [];
  }

  // The ellipse's sx axis at its cutoff (pixels) and, ROTATE pixels further out along it, the
  // rotation handle (data units): on the axis's ray, so dragging it turns the axis to the pointer.
  rotationHandle(w) {
    const [u] = Tf2Editor.axes(w), r = cutoffOf(w) * w.sigma[0];
    const c = this.toPixel(...w.center);
    const tip = this.toPixel(w.center[0] + r * u[0], w.center[1] + r * u[1]);
    const dx = tip[0] - c[0], dy = tip[1] - c[1], len = Math.hypot(dx, dy) || 1;
    return {tip, at: this.fromPixel(tip[0] + ROTATE * dx / len, tip[1] + ROTATE * dy / len)};
  }

  // [name, x, y] (data units) of the widget's handles.
  handles(w) {
    switch (w.type) {
      case 'box':
        return [['x0y0', w.x[0], w.y[0]], ['x1y0', w.x[1], w.y[0]], ['x1y1', w.x[1], w.y[1]],
                ['x0y1', w.x[0], w.y[1]]];
      case 'triangle': return [['apex', ...w.apex], ['top', w.apex[0] + w.width / 2, w.top]];
      case 'ellipse': {
        const [u, v] = Tf2Editor.axes(w);
        return [['sx', w.center[0] + w.sigma[0] * u[0], w.center[1] + w.sigma[0] * u[1]],
                ['sy', w.center[0] + w.sigma[1] * v[0], w.center[1] + w.sigma[1] * v[1]],
                ['rotate', ...this.rotationHandle(w).at]];
      }
      case 'band': return w.points.map((p, k) => [`p${k}`, ...p]);
    }
    return [];
  }

  // Whether pixel (px, py) lies on the widget (inside its outline; a band: where d <= 1, or near
  // its polyline).
  hits(w, px, py) {
    const poly = this.outline(w).map((p) => this.toPixel(...p));
    if (w.type === 'band') {
      const [x, y] = this.fromPixel(px, py), [hx, hy] = w.half_width;
      const scaled = w.points.map(([a, b]) => [a / hx, b / hy]);
      return polylineDistance([x / hx, y / hy], scaled) <= 1 || polylineDistance([px, py], poly) <= HIT;
    }
    let inside = false;
    for (let i = 0, j = poly.length - 1; i < poly.length; j = i++) {
      const [xi, yi] = poly[i], [xj, yj] = poly[j];
      if ((yi > py) !== (yj > py) && px < (xj - xi) * (py - yi) / (yj - yi) + xi) inside = !inside;
    }
    return inside;
  }

  select(i) {
    this.selected = i;
    this.onSelect(i >= 0 ? this.doc.widgets[i] : null);
    this.draw();
  }

  press(e) {
    if (e.button !== 0 || !this.editable) return;
    const [px, py] = this.eventPixel(e);
    const ws = this.doc.widgets;
    let hit = null;
    if (this.selected >= 0)
      for (const [name, x, y] of this.handles(ws[this.selected])) {
        const [qx, qy] = this.toPixel(x, y);
        if (Math.hypot(qx - px, qy - py) <= HIT) hit = {index: this.selected, handle: name};
      }
    for (let i = ws.length - 1; i >= 0 && !hit; --i)  // the topmost (last drawn) first
      if (this.hits(ws[i], px, py)) hit = {index: i, handle: 'move'};
    if (!hit) {
      this.select(-1);
      return;
    }
    if (hit.index !== this.selected) this.select(hit.index);
    this.drag = {...hit, last: this.fromPixel(px, py), moved: false};
    e.preventDefault();
  }

  move(e) {
    if (!this.drag) return;
    const [x, y] = this.fromPixel(...this.eventPixel(e));
    const w = this.doc.widgets[this.drag.index];
    const [dx, dy] = [x - this.drag.last[0], y - this.drag.last[1]];
    this.drag.last = [x, y];
    const [X0, X1, Y0, Y1] = this.domain();
    const tinyX = 1e-3 * (X1 - X0), tinyY = 1e-3 * (Y1 - Y0);
    switch (this.drag.handle) {
      case 'move': {
        const shift = (p) => [tidy(p[0] + dx), tidy(p[1] + dy)];
        if (w.type === 'box') {
          w.x = w.x.map((v) => tidy(v + dx));
          w.y = w.y.map((v) => tidy(v + dy));
        } else if (w.type === 'triangle') {
          w.apex = shift(w.apex);
          w.top = tidy(w.top + dy);
        } else if (w.type === 'ellipse') {
          w.center = shift(w.center);
        } else if (w.type === 'band') {
          w.points = w.points.map(shift);
        }
        break;
      }
      case 'x0y0': case 'x1y0': case 'x1y1': case 'x0y1': {
        // The corner moves; the box keeps x0 <= x1, y0 <= y1.
        const i = this.drag.handle[1] === '0' ? 0 : 1, j = this.drag.handle[3] === '0' ? 0 : 1;
        w.x[i] = tidy(i === 0 ? Math.min(x, w.x[1]) : Math.max(x, w.x[0]));
        w.y[j] = tidy(j === 0 ? Math.min(y, w.y[1]) : Math.max(y, w.y[0]));
        break;
      }
      case 'apex':
        w.apex = [tidy(x), tidy(Math.abs(y - w.top) < tinyY ? w.top - tinyY : y)];
        break;
      case 'top':
        w.top = tidy(Math.abs(y - w.apex[1]) < tinyY ? w.apex[1] + tinyY : y);
        w.width = tidy(Math.max(tinyX, 2 * Math.abs(x - w.apex[0])));
        break;
      case 'sx': case 'sy': {
        const [u, v] = Tf2Editor.axes(w), a = this.drag.handle === 'sx' ? u : v;
        const d = Math.abs((x - w.center[0]) * a[0] + (y - w.center[1]) * a[1]);
        w.sigma[this.drag.handle === 'sx' ? 0 : 1] =
            tidy(Math.max(this.drag.handle === 'sx' ? tinyX : tinyY, d));
        break;
      }
      case 'rotate': {
        // The sx axis points at the pointer (in data units, as the JSON's angle); 0.1° steps.
        const dx = x - w.center[0], dy = y - w.center[1];
        if (dx === 0 && dy === 0) break;
        const deg = Math.round(Math.atan2(dy, dx) * 1800 / Math.PI) / 10;
        w.angle = deg === -180 ? 180 : deg;
        break;
      }
      default:  // a band's point p<k>
        w.points[Number(this.drag.handle.slice(1))] = [tidy(x), tidy(y)];
    }
    this.drag.moved = true;
    this.draw();
    this.onSelect(w);  // the fields follow the shape
    this.onChange('drag');
  }

  release() {
    if (!this.drag) return;
    const moved = this.drag.moved;
    this.drag = null;
    this.draw();
    if (moved) this.onChange('commit');
  }

  add(type) {
    const [x0, x1, y0, y1] = this.domain(), dx = x1 - x0, dy = y1 - y0;
    const cx = x0 + dx / 2, n = this.doc.widgets.length;
    const rgba = [...PALETTE[n % PALETTE.length], 0.5];
    const w = type === 'box'
        ? {type, x: [tidy(cx - 0.05 * dx), tidy(cx + 0.05 * dx)], y: [tidy(y0 + 0.2 * dy), tidy(y0 + 0.5 * dy)], rgba}
        : type === 'triangle'
        ? {type, apex: [tidy(cx), tidy(y0)], top: tidy(y0 + 0.6 * dy), width: tidy(0.15 * dx), rgba}
        : type === 'band'
        ? {type, points: [[tidy(cx - 0.25 * dx), tidy(y0 + 0.2 * dy)], [tidy(cx), tidy(y0 + 0.5 * dy)],
                          [tidy(cx + 0.25 * dx), tidy(y0 + 0.6 * dy)]],
           half_width: [tidy(0.03 * dx), tidy(0.04 * dy)], rgba}
        : {type, center: [tidy(cx), tidy(y0 + 0.25 * dy)], sigma: [tidy(0.04 * dx), tidy(0.08 * dy)], rgba};
    this.doc.widgets.push(w);
    this.select(this.doc.widgets.length - 1);
    this.onChange('commit');
  }

  removeSelected() {
    if (this.selected < 0) return;
    this.doc.widgets.splice(this.selected, 1);
    this.select(-1);
    this.onChange('commit');
  }

  // Colour [r, g, b] in [0, 1] and/or the peak opacity of the selected widget.
  setSelectedRgba(rgb, a, phase) {
    const w = this.doc.widgets[this.selected];
    if (!w) return;
    w.rgba = [...(rgb || w.rgba.slice(0, 3)).map(tidy), tidy(a === undefined ? w.rgba[3] : a)];
    this.draw();
    this.onChange(phase);
  }

  // The selected ellipse's angle (degrees) or band's half widths [hx, hy] (> 0), from the fields;
  // a value that is not a finite number (or not > 0) is not taken.
  setSelectedAngle(deg, phase) {
    const w = this.doc.widgets[this.selected];
    if (!w || w.type !== 'ellipse') return;
    if (Number.isFinite(deg)) w.angle = tidy(deg);
    else if (phase !== 'commit') return;  // a refused value still ends the edit: the full frame
    this.draw();
    this.onChange(phase);
  }

  setSelectedHalfWidth(half, phase) {
    const w = this.doc.widgets[this.selected];
    if (!w || w.type !== 'band') return;
    if (half.every((v) => Number.isFinite(v) && v > 0)) w.half_width = half.map(tidy);
    else if (phase !== 'commit') return;
    this.draw();
    this.onChange(phase);
  }

  // A band's region d <= 1: its polyline stroked 2 wide with round caps and joins in (x/hx, y/hy)
  // units, which is the set within distance 1 of the polyline there.
  fillBand(ctx, w, style) {
    const [hx, hy] = w.half_width, [x0, x1, y0, y1] = this.domain(), b = this.plotBox();
    const [ox, oy] = this.toPixel(0, 0);
    ctx.save();
    ctx.transform(hx * b.w / (x1 - x0), 0, 0, -hy * b.h / (y1 - y0), ox, oy);
    ctx.beginPath();
    if (w.points.length === 1) {
      ctx.arc(w.points[0][0] / hx, w.points[0][1] / hy, 1, 0, 2 * Math.PI);
      ctx.fillStyle = style;
      ctx.fill();
    } else {
      w.points.forEach(([x, y], k) => (k ? ctx.lineTo(x / hx, y / hy) : ctx.moveTo(x / hx, y / hy)));
      ctx.lineWidth = 2;
      ctx.lineCap = ctx.lineJoin = 'round';
      ctx.strokeStyle = style;
      ctx.stroke();
    }
    ctx.restore();
  }

  buildHistogramImage() {
    const h = this.histogram, [nx, ny] = h.bins;
    const img = new ImageData(nx, ny);
    const f = (c) => (this.log ? Math.log1p(c) : c);
    let top = 0;
    for (const c of h.counts) top = Math.max(top, f(c));
    for (let j = 0; j < ny; ++j)
      for (let i = 0; i < nx; ++i) {
        const g = 255 - Math.round(255 * f(h.counts[j * nx + i]) / (top || 1));
        const k = ((ny - 1 - j) * nx + i) * 4;  // row 0 at the bottom
        img.data[k] = img.data[k + 1] = img.data[k + 2] = g;
        img.data[k + 3] = 255;
      }
    const c = document.createElement('canvas');
    c.width = nx, c.height = ny;
    c.getContext('2d').putImageData(img, 0, 0);
    this.histogramImage = c;
  }

  draw() {
    const ctx = this.canvas.getContext('2d'), b = this.plotBox();
    const [x0, x1, y0, y1] = this.domain();
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    ctx.fillStyle = '#fff';
    ctx.fillRect(b.x, b.y, b.w, b.h);
    const h = this.histogram;
    if (h && h.domain.every((v, k) => v === this.doc.domain[k])) {
      if (!this.histogramImage) this.buildHistogramImage();
      ctx.imageSmoothingEnabled = false;
      ctx.drawImage(this.histogramImage, b.x, b.y, b.w, b.h);
    }
    ctx.save();
    ctx.beginPath();
    ctx.rect(b.x, b.y, b.w, b.h);
    ctx.clip();
    this.doc.widgets.forEach((w, i) => {
      const pts = this.outline(w).map((p) => this.toPixel(...p));
      const [r, g, bl] = w.rgba.map((v) => Math.round(255 * v));
      const fill = `rgba(${r},${g},${bl},${0.15 + 0.5 * w.rgba[3]})`;
      if (w.type === 'band') this.fillBand(ctx, w, fill);
      ctx.beginPath();
      pts.forEach(([px, py], k) => (k ? ctx.lineTo(px, py) : ctx.moveTo(px, py)));
      if (w.type !== 'band') {
        ctx.closePath();
        ctx.fillStyle = fill;
        ctx.fill();
      }
      ctx.strokeStyle = i === this.selected ? '#000' : `rgb(${r},${g},${bl})`;
      ctx.lineWidth = i === this.selected ? 2 : 1.2;
      ctx.stroke();
      if (w.type === 'ellipse') {  // the 1σ contour, dashed
        const one = {...w, cutoff: 1};
        ctx.setLineDash([3, 3]);
        ctx.beginPath();
        this.outline(one).map((p) => this.toPixel(...p))
            .forEach(([px, py], k) => (k ? ctx.lineTo(px, py) : ctx.moveTo(px, py)));
        ctx.closePath();
        ctx.stroke();
        ctx.setLineDash([]);
      }
    });
    ctx.restore();
    const sel = this.doc.widgets[this.selected];
    if (sel && this.editable && sel.type === 'ellipse') {  // the rotation handle's arm
      const {tip, at} = this.rotationHandle(sel), [px, py] = this.toPixel(...at);
      ctx.strokeStyle = '#000';
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(...tip);
      ctx.lineTo(px, py);
      ctx.stroke();
    }
    if (sel && this.editable)
      for (const [name, x, y] of this.handles(sel)) {
        const [px, py] = this.toPixel(x, y);
        ctx.fillStyle = '#fff';
        ctx.strokeStyle = '#000';
        ctx.lineWidth = 1.5;
        ctx.beginPath();
        if (name === 'rotate') ctx.arc(px, py, 5, 0, 2 * Math.PI);  // round: turns, not resizes
        else ctx.rect(px - 4, py - 4, 8, 8);
        ctx.fill();
        ctx.stroke();
      }
    ctx.strokeStyle = '#888';
    ctx.lineWidth = 1;
    ctx.strokeRect(b.x, b.y, b.w, b.h);
    ctx.fillStyle = '#444';
    ctx.font = '11px sans-serif';
    ctx.textBaseline = 'top';
    const num = (v) => String(Number(v.toPrecision(4)));
    ctx.fillText(num(x0), b.x, b.y + b.h + 3);
    ctx.fillText(num(x1), b.x + b.w - ctx.measureText(num(x1)).width, b.y + b.h + 3);
    const xl = h ? h.x : 'x';
    ctx.fillText(xl, b.x + (b.w - ctx.measureText(xl).width) / 2, b.y + b.h + 18);
    ctx.textBaseline = 'middle';
    ctx.fillText(num(y1), b.x - 4 - ctx.measureText(num(y1)).width, b.y + 5);
    ctx.fillText(num(y0), b.x - 4 - ctx.measureText(num(y0)).width, b.y + b.h - 5);
    ctx.save();
    ctx.translate(12, b.y + b.h / 2);
    ctx.rotate(-Math.PI / 2);
    const yl = h ? h.y : 'y';
    ctx.fillText(yl, -ctx.measureText(yl).width / 2, 0);
    ctx.restore();
  }
}
