// udvr serve's page: the rendered views, the camera (SPEC §5's azimuth/elevation/zoom, so every
// view is one `udvr render` command line), progressive frames, the model picker, the quartile
// view, the ground truth with its difference and RMSE, the TF editor and the click probe.
import {ApiError, getJson, getRender, getText, postJson} from './api.js';
import {PLOT_STEPS, drawProbePlot, plotModels, plotRange} from './probe_plot.js';
import {TfEditor, colourAt, opacityAt, parseParaViewTf, toParaViewJson} from './tf_editor.js';
import {Tf2Editor} from './tf2_editor.js';

const $ = (id) => document.getElementById(id);
const COARSE = 4;  // coarse frames: 1/4 of the width and height
let HOME = null;  // SPEC §5's default camera: /api/state's defaults (the library's), from start()

const state = {
  info: null,
  model: null,            // the picked model's name (the server's defaults.model at start)
  camera: null,           // {azimuth, elevation, zoom}: HOME until the view is turned
  size: null,             // [w, h]: /api/state's default size (the library's), from start()
  quartiles: false,
  seq: 0,                 // request counter: orders a channel's requests on the server
  views: new Map(),       // channel -> view
  probe: null,            // {pixel, point, model, models: {name: json}, tf2Row}
  probing: 0,
  posters: [],            // the TF posters (tfPoster): busy while posting
  estimating: false,      // the models' estimates are being asked again (refreshEstimates)
  timings: [],            // {kind, channel, size, realizations, latency (event -> pixels, ms), render (ms)}
};

// This page load's own channels on the server: its seq counts from 1 whatever an older load (or
// another tab) sent there.
const PAGE = Array.from(crypto.getRandomValues(new Uint8Array(8)),
                        (b) => b.toString(16).padStart(2, '0')).join('');

// Numbers as sent to the server and shown in the command line (the same text).
const fmt = {
  angle: (v) => String(Math.round(v * 10) / 10),
  zoom: (v) => String(Math.round(v * 1000) / 1000),
};

function cameraParams() {
  return {azimuth: fmt.angle(state.camera.azimuth), elevation: fmt.angle(state.camera.elevation),
          zoom: fmt.zoom(state.camera.zoom)};
}

function sizeText() {
  const [w, h] = state.size;
  return `${w}x${h}`;
}

function modelInfo(name) {
  return state.info.models.find((m) => m.name === name);
}

// The quartile view's models (SPEC §4): those covering a proper part of the quantile population
// ([lo, hi] ⊂ [0, 1], from the server's model table), in rank order.
function quartileViews() {
  return state.info.models
      .filter((m) => m.population && (m.population[0] > 0 || m.population[1] < 1))
      .sort((a, b) => a.population[0] - b.population[0])
      .map((m) => m.name);
}

// A view's full frame, estimated: the server's probe of the model at its default view
// (estimate_size, the TF when the page loaded), scaled by the pixel count. 0: unknown.
function estimateMs(params) {
  if (params.source === 'truth') return 0;  // the truth renders as `mean`
  const m = modelInfo(params.model);
  if (!m || !m.estimate_ms) return 0;
  const [w0, h0] = state.info.estimate_size.split('x').map(Number);
  const [w, h] = state.size;
  return m.estimate_ms * (w * h) / (w0 * h0) * (params.source === 'diff' ? 1.1 : 1);
}

// Whether the view's model is rendered as an average of realizations (gmm-mc): its cost goes with
// the realizations, each costing about as much at any image size (drawing it over the voxels).
function byRealizations(params) {
  const m = params.source === 'truth' ? null : modelInfo(params.model);
  return !!(m && m.realizations);
}

// Progressive steps of a frame over the latency goal, from the first step whose estimate meets
// the goal up to the full frame, each 4x cheaper than the next: the side halved `step` times,
// or for gmm-mc the full side with the realizations divided by 4^step (at least 2); each step is
// a request that the next input's request cancels. 0: one frame. A lower bound (the server's
// probe ran out of time) starts two steps down.
function progressiveSteps(params) {
  const goal = state.info.latency_goal_ms;
  const fits = byRealizations(params)
      ? (steps) => state.info.defaults.realizations >> (2 * steps) >= 2
      : (steps) => Math.min(...state.size) >> steps >= 8;
  let steps = 0;
  for (let ms = estimateMs(params); ms > goal && fits(steps + 1); ms /= 4) ++steps;
  const m = params.source === 'truth' ? null : modelInfo(params.model);
  if (m && m.estimate_lower_bound) while (steps < 2 && fits(steps + 1)) ++steps;
  return steps;
}

// The size (and for gmm-mc the realizations) of progressive step `step` of a view.
function stepParams(params, step) {
  const [w, h] = state.size;
  if (byRealizations(params))
    return {size: `${w}x${h}`, realizations: state.info.defaults.realizations >> (2 * step)};
  return {size: `${Math.max(1, w >> step)}x${Math.max(1, h >> step)}`};
}

// The coarse frame of a view (dragging, editing): 1/COARSE of the side, and the side halved
// again while the model's estimate for that size is over the latency goal (down to
// COARSE_MIN_SIDE pixels): a 2D gaussian's 128² coarse frame took 1.3 s, its 64² one 0.35 s.
// gmm-mc's cost goes with its realizations, not the size: its coarse frames stay at 1/COARSE.
const COARSE_MIN_SIDE = 16;
function coarseSize(params) {
  const [w, h] = state.size;
  let shrink = COARSE;
  if (!byRealizations(params)) {
    const goal = state.info.latency_goal_ms;
    for (let ms = estimateMs(params) / (COARSE * COARSE);
         ms > goal && Math.min(w, h) / (2 * shrink) >= COARSE_MIN_SIDE; ms /= 4)
      shrink *= 2;
  }
  return `${Math.max(1, Math.round(w / shrink))}x${Math.max(1, Math.round(h / shrink))}`;
}

function stepText(params, step) {
  return byRealizations(params) ? `1/${1 << (2 * step)} of the realizations`
                                : `1/${1 << step} of the side`;
}

function secondsText(ms) {
  return ms < 60000 ? `${(ms / 1000).toFixed(ms < 10000 ? 1 : 0)} s` : `${(ms / 60000).toFixed(1)} min`;
}

// ---- status line --------------------------------------------------------------------------
function showError(e) {
  if (e instanceof ApiError && e.status === 409) return;  // superseded: a newer frame follows
  const s = $('status');
  s.textContent = e.message || String(e);
  s.className = 'error';
}
function showInfo(text) {
  const s = $('status');
  s.textContent = text;
  s.className = '';
}

// ---- views --------------------------------------------------------------------------------
function wantedViews() {
  const list = [{channel: 'main', title: modelInfo(state.model).label, params: {model: state.model}}];
  if (state.quartiles)
    for (const q of quartileViews()) list.push({channel: q, title: q, params: {model: q}});
  if (state.info.truth) {
    list.push({channel: 'truth', title: 'ground truth', params: {model: state.model, source: 'truth'}});
    list.push({channel: 'diff', title: 'difference', params: {model: state.model, source: 'diff'}});
  }
  return list;
}

function buildViews() {
  const container = $('views');
  const wanted = wantedViews();
  for (const [channel, v] of state.views)
    if (!wanted.some((w) => w.channel === channel)) v.figure.remove(), state.views.delete(channel);
  for (const w of wanted) {
    let v = state.views.get(w.channel);
    if (!v) {
      const figure = document.createElement('figure');
      figure.className = 'view';
      figure.dataset.channel = w.channel;
      const canvas = document.createElement('canvas');
      const caption = document.createElement('figcaption');
      figure.append(canvas, caption);
      v = {channel: w.channel, figure, canvas, caption, inFlight: new Map(), pending: null,
           shownSeq: 0, shown: null, info: ''};
      state.views.set(w.channel, v);
      attachCamera(canvas, w.channel === 'main');
    }
    v.title = w.title;
    v.params = w.params;
    container.append(v.figure);  // in the wanted order
  }
  layoutViews();
}

function layoutViews() {
  const [w, h] = state.size;
  const n = state.views.size;
  const room = $('views').clientWidth || 1200;
  const scale = Math.min(1, (room - 16 * n) / (n * w));
  const shown = Math.max(160, Math.floor(w * (n > 1 ? scale : 1)));
  for (const v of state.views.values()) {
    v.canvas.style.width = shown + 'px';
    v.canvas.style.height = Math.round(shown * h / w) + 'px';
    v.caption.style.width = shown + 'px';
  }
}

function captionOf(v) {
  const rmse = v.channel === 'diff' && v.rmse !== undefined ? ` · RMSE ${v.rmse}` : '';
  return `${v.title}${rmse} — ${v.info}`;
}

// Ask every view for a frame: coarse while dragging or editing, full on release.
function schedule(coarse) {
  const eventTime = performance.now();
  for (const v of state.views.values()) {
    // A full frame over the latency goal comes in steps, coarse first (progressiveSteps).
    const step = coarse ? 0 : progressiveSteps(v.params);
    v.pending = {kind: coarse ? 'coarse' : step > 0 ? 'step' : 'full', eventTime, step};
    v.decided = {...v.pending};  // revisited when the estimates change (redecideSteps)
    pump(v);
  }
  updateCommand();
}

// Send a view's pending request. A coarse one waits while a coarse one is on its way (it is
// quick; the pending one follows it, so dragging shows frames); a full one goes at once. A
// request cancels the frame rendering on its channel on the server.
function pump(v) {
  if (!v.pending) return;
  if (v.pending.kind === 'coarse' && [...v.inFlight.values()].includes('coarse')) return;
  const {kind, eventTime, step} = v.pending;
  v.pending = null;
  const seq = ++state.seq;
  v.inFlight.set(seq, kind);
  const sized = kind === 'step' ? stepParams(v.params, step)
              : {size: kind === 'coarse' ? coarseSize(v.params) : sizeText()};
  const params = {...v.params, ...sized, ...cameraParams(), channel: v.channel, seq, page: PAGE};
  const query = JSON.stringify({...params, channel: undefined, seq: undefined, page: undefined});
  // The PNG's 8-bit RGBA values without the PNG (no encoding, no decoding): the PNG itself is
  // asked for when saved (pngOf).
  getRender({...params, format: 'rgba'})
      .then(async ({bytes, headers}) => {
        const arrived = performance.now();
        const image = {width: Number(headers.get('X-Udvr-Width')),
                       height: Number(headers.get('X-Udvr-Height')), rgba: new Uint8ClampedArray(bytes)};
        if (seq < v.shownSeq) return;  // a newer frame is already shown
        v.shownSeq = seq;
        // RGB is already composited over the background (SPEC §5): shown opaque.
        for (let i = 3; i < image.rgba.length; i += 4) image.rgba[i] = 255;
        v.canvas.width = image.width;
        v.canvas.height = image.height;
        v.canvas.getContext('2d').putImageData(new ImageData(image.rgba, image.width, image.height), 0, 0);
        v.shown = {kind, query};
        const renderMs = Number(headers.get('X-Udvr-Render-Ms'));
        if (headers.get('X-Udvr-Rmse')) v.rmse = Number(headers.get('X-Udvr-Rmse')).toFixed(5);
        await new Promise(requestAnimationFrame);
        const latency = performance.now() - eventTime;
        // ms after the input: the answer's bytes here, and within it the server's part.
        state.timings.push({kind, channel: v.channel, size: sized.size,
                            realizations: sized.realizations, latency, render: renderMs,
                            server: Number(headers.get('X-Udvr-Server-Ms')),
                            arrived: arrived - eventTime});
        const what = kind === 'step' ? `step (${stepText(v.params, step)}; the full frame: ` +
                                           `about ${secondsText(estimateMs(v.params))})` : kind;
        v.info = `${what} ${image.width}×${image.height}, render ${renderMs.toFixed(0)} ms, ` +
                 `shown ${latency.toFixed(0)} ms after the input`;
        v.caption.textContent = captionOf(v);
        v.figure.classList.toggle('coarse', kind !== 'full');
        // The next finer step, unless a newer input (or new estimates) asked for something else.
        const newest = Math.max(...v.inFlight.keys()) === seq;
        if (kind === 'step' && !v.pending && v.shownSeq === seq && newest)
          v.pending = {kind: step > 1 ? 'step' : 'full', eventTime, step: step - 1};
      })
      .catch(showError)
      .finally(() => {
        v.inFlight.delete(seq);
        pump(v);
      });
}

// ---- camera -------------------------------------------------------------------------------
function attachCamera(canvas, probes) {
  let drag = null;
  canvas.addEventListener('pointerdown', (e) => {
    if (e.button !== 0) return;
    canvas.setPointerCapture(e.pointerId);
    drag = {x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, moved: false};
  });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX, drag.y = e.clientY;
    if (Math.hypot(e.clientX - drag.x0, e.clientY - drag.y0) > 3) drag.moved = true;
    if (!drag.moved) return;
    state.camera.azimuth -= 0.5 * dx;
    state.camera.elevation = Math.max(-89, Math.min(89, state.camera.elevation + 0.5 * dy));
    schedule(true);
  });
  const end = (e) => {
    if (!drag) return;
    const moved = drag.moved;
    drag = null;
    if (moved) schedule(false);
    else if (probes && e.type === 'pointerup') probeAt(canvas, e);
  };
  canvas.addEventListener('pointerup', end);
  canvas.addEventListener('pointercancel', end);
  let wheelTimer = 0;
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    state.camera.zoom = Math.max(0.1, Math.min(20, state.camera.zoom * Math.exp(-0.0015 * e.deltaY)));
    schedule(true);
    clearTimeout(wheelTimer);
    wheelTimer = setTimeout(() => schedule(false), 150);
  }, {passive: false});
  canvas.addEventListener('dblclick', () => {
    state.camera = {...HOME};
    schedule(false);
  });
}

// ---- command lines ------------------------------------------------------------------------
function updateCommand() {
  const c = cameraParams();
  const tfFlags = state.info.tf2
      ? `--tf2 ${state.info.tf2_editable ? 'tf2.json' : state.info.tf2}` +
        (state.info.second ? ` --second ${state.info.second}` : '')
      : '--tf tf.json';
  const common = `${tfFlags} --size ${sizeText()} --azimuth ${c.azimuth} ` +
                 `--elevation ${c.elevation} --zoom ${c.zoom}`;
  const lines = [`udvr render ${state.info.model.file} --model ${state.model} ${common} -o view.png`];
  if (state.info.truth) {
    lines.push(`udvr render ${state.info.truth} --model mean ${common} -o truth.png`);
    lines.push('udvr compare view.png truth.png --diff diff.png');
  }
  if (state.probe) {
    const p = state.probe.point.join(',');
    lines.push(`udvr probe ${state.info.model.file} --point ${p} --model ${state.probe.model} ` +
               `${tfFlags} --json`);
  }
  $('command').textContent = lines.join('\n');
}

// ---- probe --------------------------------------------------------------------------------
async function probeAt(canvas, e) {
  const r = canvas.getBoundingClientRect();
  const [w, h] = state.size;
  const x = Math.min(w - 1, Math.floor((e.clientX - r.left) / r.width * w));
  const y = Math.min(h - 1, Math.floor((e.clientY - r.top) / r.height * h));
  // A model without a distribution at a point (gmm-mc) is probed as the server says.
  const model = modelInfo(state.model).probe_as || plotModels(state.info.models)[0].name;
  state.probing++;
  try {
    const hit = await getJson('/api/probe', {model, size: sizeText(), ...cameraParams(), x, y});
    const models = {[model]: hit};
    for (const m of plotModels(state.info.models)) {
      if (models[m.name] || !modelInfo(m.name).available) continue;
      models[m.name] = await getJson('/api/probe', {model: m.name, point: hit.point.join(',')});
    }
    const probe = {pixel: [x, y], point: hit.point, model, models};
    probe.tf2Row = await tf2RowOf(probe);
    state.probe = probe;
    const marker = $('marker');
    marker.style.left = `${canvas.offsetLeft + (x + 0.5) / w * r.width}px`;
    marker.style.top = `${canvas.offsetTop + (y + 0.5) / h * r.height}px`;
    marker.hidden = false;
    showProbe();
  } catch (err) {
    showError(err);
  } finally {
    state.probing--;
  }
}

// With --tf2: the TF2 along the plot's x at y = the probed model's mean gradient magnitude E[G]
// at the point (with --second: field 2's mean there), GET /api/tf2/row; else null.
async function tf2RowOf(p) {
  const range = plotRange(p.models, plotModels(state.info.models));
  if (!state.info.tf2 || !range) return null;
  const g = p.models[p.model].gradient_magnitude;
  const row = await getJson('/api/tf2/row', {y: g.mean, lo: range[0], hi: range[1], n: PLOT_STEPS + 1});
  const sd = g.stddev > 0 ? `, σ ${g.stddev.toPrecision(3)}` : '';
  row.label = `2D TF α at ${state.info.second ? 'field 2' : '|∇|'} = ${g.mean.toPrecision(4)} (mean${sd})`;
  row.note = `dashed: the 2D TF's opacity (the strip: its colour) along ` +
      (state.info.second ? 'field 1 at field 2' : 'the value at gradient magnitude') +
      ` ${g.mean}, ${p.model}'s mean at the point${sd}`;
  return row;
}

// What the plot draws beneath the distributions: the 1D TF, or the TF2's row (linear between
// its samples, which lie on the plot's steps). The TF2's colour is 0 where α is: its strip is
// the colour over white with weight 0.85·α/α_max, as `udvr tf2 --png` draws a TF2.
function beneathOf(p) {
  const row = p.tf2Row;
  if (!row) return {alpha: (x) => opacityAt(editor.tf.points, x), colour: (x) => colourAt(editor.tf.rgb, x)};
  const n = row.x.length, lo = row.x[0], hi = row.x[n - 1];
  const top = Math.max(...row.rgba.map((c) => c[3]));
  const at = (x, ch) => {
    const s = Math.max(0, Math.min(n - 1, (x - lo) / (hi - lo) * (n - 1))), k = Math.min(n - 2, Math.floor(s));
    return row.rgba[k][ch] + (s - k) * (row.rgba[k + 1][ch] - row.rgba[k][ch]);
  };
  const colour = (x) => {
    const w = top > 0 ? 0.85 * at(x, 3) / top : 0;
    return [0, 1, 2].map((ch) => w * at(x, ch) + (1 - w));
  };
  return {alpha: (x) => at(x, 3), colour, label: row.label};
}

function showProbe() {
  const p = state.probe;
  if (!p) return;
  drawProbePlot($('probe-plot'), p.models, plotModels(state.info.models), beneathOf(p));
  $('probe-tf2').textContent = p.tf2Row ? p.tf2Row.note : '';
  const table = $('probe-table');
  table.replaceChildren();
  const keys = ['value', 'mean', 'stddev', 'low', 'high', 'boundaries', 'weights', 'means', 'sigmas',
                'expected_rgba'];
  for (const [name, j] of Object.entries(p.models)) {
    const row = table.insertRow();
    row.dataset.model = name;
    row.dataset.json = JSON.stringify(j);
    row.insertCell().textContent = name;
    const cell = row.insertCell();
    cell.textContent = keys.filter((k) => k in j)
        .map((k) => `${k} ${Array.isArray(j[k]) ? j[k].map((v) => v.toPrecision(5)).join(' ') : j[k].toPrecision(6)}`)
        .join('; ');
  }
  const w = p.models[p.model].world;
  $('probe-where').textContent =
      `pixel (${p.pixel}) → index (${p.point.map((v) => v.toFixed(3)).join(', ')})` +
      (w ? `, world (${w.map((v) => v.toPrecision(5)).join(', ')})` : '');
  updateCommand();
}

// ---- transfer function --------------------------------------------------------------------
const editor = new TfEditor($('tf-canvas'), (phase) => tfChanged(phase));

// A TF's poster: posts `body()` to `path` (one POST at a time, the newest waiting), then renders:
// coarse frames while dragging, the full frame on release ('commit').
function tfPoster(path, body) {
  const p = {busy: false, pending: null};
  p.changed = async (phase) => {
    p.pending = p.pending === 'commit' || phase === 'commit' ? 'commit' : 'drag';
    if (p.busy) return;
    p.busy = true;
    let committed = false;
    try {
      while (p.pending) {
        const kind = p.pending;
        p.pending = null;
        await postJson(path, body());
        schedule(kind === 'drag');
        committed = committed || kind === 'commit';
        // An edit made while the probe refreshes is pending again: the loop goes on.
        if (!p.pending && state.probe) await refreshProbe();
      }
    } catch (e) {
      showError(e);
    } finally {
      p.busy = false;
    }
    if (committed) refreshEstimates();
  };
  state.posters.push(p);
  return p.changed;
}

const tfChanged = tfPoster('/api/tf', () => toParaViewJson(editor.tf));

// The probe's expected colours depend on the TF: ask again at the same point.
async function refreshProbe() {
  const p = state.probe;
  for (const name of Object.keys(p.models))
    p.models[name] = await getJson('/api/probe', {model: name, point: p.point.join(',')});
  p.tf2Row = await tf2RowOf(p);
  showProbe();
}

async function applyTfText(text) {
  const tf = parseParaViewTf(text);  // a quick check; the server checks everything
  await postJson('/api/tf', toParaViewJson(tf));
  editor.setTf(tf);
  schedule(false);
  refreshEstimates();
  if (state.probe) await refreshProbe();
}

function download(blob, name) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.append(a);
  a.click();
  setTimeout(() => (URL.revokeObjectURL(a.href), a.remove()), 1000);
}

// ---- 2D transfer function ---------------------------------------------------------------
const editor2 = new Tf2Editor($('tf2-canvas'), (phase) => tf2Changed(phase), (w) => tf2Selected(w));

const hex = (rgb) => '#' + rgb.map((v) => Math.round(255 * v).toString(16).padStart(2, '0')).join('');

function tf2Selected(w) {
  for (const id of ['tf2-delete', 'tf2-colour', 'tf2-opacity']) $(id).disabled = !w;
  $('tf2-angle-field').hidden = !w || w.type !== 'ellipse';
  $('tf2-half-field').hidden = !w || w.type !== 'band';
  if (!w) {
    $('tf2-opacity-value').textContent = '';
    return;
  }
  $('tf2-colour').value = hex(w.rgba.slice(0, 3));
  $('tf2-opacity').value = w.rgba[3];
  $('tf2-opacity-value').textContent = w.rgba[3].toFixed(2);
  if (w.type === 'ellipse') $('tf2-angle').value = w.angle || 0;
  if (w.type === 'band') [$('tf2-hx').value, $('tf2-hy').value] = w.half_width;
}

const tf2Changed = tfPoster('/api/tf2', () => JSON.stringify(editor2.doc));

// A raster TF2 is view-only: no widgets to edit or save.
function tf2Editable(on) {
  editor2.editable = on;
  for (const id of ['tf2-add-box', 'tf2-add-triangle', 'tf2-add-ellipse', 'tf2-add-band', 'tf2-save'])
    $(id).disabled = !on;
}

async function startTf2() {
  $('tf-panel').hidden = true;
  $('tf2-panel').hidden = false;
  const note = state.info.tf2_editable ? '' :
      `: a raster, view-only (start with a widget .json to edit it)`;
  showInfo(`renders use the 2D TF ${state.info.tf2}${note}`);
  if (state.info.tf2_editable) {
    editor2.setDoc(JSON.parse(await getText('/api/tf2')));
  } else {
    tf2Editable(false);
    $('tf2-hint').textContent = 'a raster 2D TF: shown over the histogram by its domain only';
  }
  const h = await getJson('/api/histogram2d', {bins: 128});
  if (!state.info.tf2_editable) editor2.setDoc({domain: h.domain, widgets: []});
  editor2.setHistogram(h);
  for (const type of ['box', 'triangle', 'ellipse', 'band'])
    $(`tf2-add-${type}`).addEventListener('click', () => editor2.add(type));
  $('tf2-delete').addEventListener('click', () => editor2.removeSelected());
  window.addEventListener('keydown', (e) => {
    if ((e.key === 'Delete' || e.key === 'Backspace') && e.target === document.body)
      editor2.removeSelected();
  });
  $('tf2-log').addEventListener('change', () => editor2.setLog($('tf2-log').checked));
  const rgb = () => [1, 3, 5].map((k) => parseInt($('tf2-colour').value.slice(k, k + 2), 16) / 255);
  $('tf2-colour').addEventListener('input', () => editor2.setSelectedRgba(rgb(), undefined, 'drag'));
  $('tf2-colour').addEventListener('change', () => editor2.setSelectedRgba(rgb(), undefined, 'commit'));
  const opacity = (phase) => {
    const a = Number($('tf2-opacity').value);
    $('tf2-opacity-value').textContent = a.toFixed(2);
    editor2.setSelectedRgba(null, a, phase);
  };
  $('tf2-opacity').addEventListener('input', () => opacity('drag'));
  $('tf2-opacity').addEventListener('change', () => opacity('commit'));
  // Typing or the spinner: coarse frames; leaving the field or Enter: the full frame.
  const angle = (phase) => editor2.setSelectedAngle($('tf2-angle').valueAsNumber, phase);
  const half = (phase) => editor2.setSelectedHalfWidth(
      [$('tf2-hx').valueAsNumber, $('tf2-hy').valueAsNumber], phase);
  for (const [ids, set] of [[['tf2-angle'], angle], [['tf2-hx', 'tf2-hy'], half]])
    for (const id of ids) {
      $(id).addEventListener('input', () => set('drag'));
      $(id).addEventListener('change', () => {
        set('commit');
        tf2Selected(editor2.doc.widgets[editor2.selected]);  // a refused value: the widget's again
      });
    }
  loadAndSave('tf2', '/api/tf2', 'tf2.json', async (text) => {
    await postJson('/api/tf2', text);  // the server checks everything
    editor2.setDoc(JSON.parse(await getText('/api/tf2')));
    tf2Editable(true);  // a loaded widget file replaces a raster TF2
    editor2.select(-1);
    editor2.setHistogram(await getJson('/api/histogram2d', {bins: 128}));  // the domain may differ
    schedule(false);
    refreshEstimates();
  });
}

// The load (file input `${prefix}-load`, its text to `apply`) and save buttons of a TF panel.
function loadAndSave(prefix, path, name, apply) {
  const input = $(`${prefix}-load`);
  input.addEventListener('change', async () => {
    const file = input.files[0];
    if (!file) return;
    try {
      await apply(await file.text());
      showInfo(`loaded ${file.name}`);
    } catch (e) {
      showError(e);
    }
    input.value = '';
  });
  $(`${prefix}-save`).addEventListener('click', async () => {
    download(new Blob([await getText(path)], {type: 'application/json'}), name);
  });
}

// ---- estimates ----------------------------------------------------------------------------
// Models over the latency goal are marked with their estimate and render progressively.
function markOption(o, m) {
  o.text = m.slow ? `${m.label} — ${m.estimate_lower_bound ? 'over' : 'about'} ` +
                    `${secondsText(m.estimate_ms)} (progressive)` : m.label;
  o.title = m.available ? '' : m.reason;
  if (m.slow)
    o.title = `a ${state.info.estimate_size} frame is estimated at ${secondsText(m.estimate_ms)}, ` +
              `over the ${state.info.latency_goal_ms} ms goal: shown coarse first, then finer`;
  if (m.slow) o.dataset.slow = 'true';
  else delete o.dataset.slow;
}

// The estimates are for one TF (the server drops them when it changes): after an edit (1D or 2D,
// posted, loaded or a preset) the page asks again, marks the picker anew and revisits the views'
// progressive-step decisions. Debounced (an edit within ESTIMATES_DEBOUNCE_MS of the last waits
// with it), and never more than one request in flight: a newer edit aborts the older request
// (the server's probes stop when their client goes: its estimates were for a TF already gone)
// and asks once its own debounce ends.
const ESTIMATES_DEBOUNCE_MS = 300;
const estimates = {timer: 0, abort: null, inFlight: null, generation: 0};
function refreshEstimates() {
  state.estimating = true;
  const generation = ++estimates.generation;
  if (estimates.abort) estimates.abort.abort();
  clearTimeout(estimates.timer);
  estimates.timer = setTimeout(async () => {
    if (estimates.inFlight) await estimates.inFlight;  // the aborted one settles first
    if (generation !== estimates.generation) return;  // a newer edit took over meanwhile
    const abort = new AbortController();
    estimates.abort = abort;
    estimates.inFlight = askEstimates(abort.signal, generation);
    await estimates.inFlight;
    estimates.inFlight = null;
    if (generation === estimates.generation) {
      estimates.abort = null;
      state.estimating = false;
    }
  }, ESTIMATES_DEBOUNCE_MS);
}

async function askEstimates(signal, generation) {
  let info;
  try {
    info = await getJson('/api/state', {estimates: 1}, {signal});
  } catch (e) {
    if (!signal.aborted) showError(e);
    return;
  }
  if (generation !== estimates.generation) return;
  for (const fresh of info.models) {
    const m = modelInfo(fresh.name);
    if (!m) continue;
    for (const k of ['estimate_ms', 'estimate_lower_bound', 'slow']) m[k] = fresh[k];
    const o = [...$('model').options].find((o) => o.value === m.name);
    if (o) markOption(o, m);
  }
  redecideSteps();
}

// A view whose full frame was asked for with the old TF's estimates, and whose progressive-step
// decision differs with the new ones, asks again: a model the new TF made slow comes in steps
// (its full frame, on its way, is cancelled), one made quick skips its remaining steps. A view
// already showing its full frame, or dragging (coarse), is left as it is.
function redecideSteps() {
  for (const v of state.views.values()) {
    if (!v.decided || v.decided.kind === 'coarse') continue;
    const steps = progressiveSteps(v.params);
    if (steps === v.decided.step) continue;
    const pending = v.pending && v.pending.kind !== 'coarse';
    const working = [...v.inFlight.values()].some((kind) => kind !== 'coarse');
    if (!pending && !working) continue;
    v.pending = {kind: steps > 0 ? 'step' : 'full', eventTime: v.decided.eventTime, step: steps};
    v.decided = {...v.pending};
    pump(v);
  }
}

// ---- start --------------------------------------------------------------------------------
async function start() {
  state.info = await getJson('/api/state', {estimates: 1});  // with each model's frame estimate
  const {azimuth, elevation, zoom} = state.info.defaults;
  HOME = {azimuth, elevation, zoom};
  state.camera = {...HOME};
  state.size = state.info.defaults.size.split('x').map(Number);
  const sizes = $('size');
  if (![...sizes.options].some((o) => Number(o.value) === state.size[0]))
    sizes.add(new Option(`${state.size[0]}²`, String(state.size[0])));
  sizes.value = String(state.size[0]);  // the picker offers squares; the default is one
  $('title').textContent = `udvr serve — ${state.info.model.file}`;
  const picker = $('model');
  for (const m of state.info.models) {
    const o = new Option(m.label, m.name);
    o.disabled = !m.available;
    picker.add(o);
    markOption(o, m);
  }
  state.model = state.info.defaults.model;
  picker.value = state.model;
  picker.addEventListener('change', () => {
    state.model = picker.value;
    buildViews();
    schedule(false);
  });
  const quartiles = $('quartiles');
  const views = quartileViews();
  quartiles.disabled = views.length === 0 || !views.every((n) => modelInfo(n).available);
  quartiles.addEventListener('change', () => {
    state.quartiles = quartiles.checked;
    buildViews();
    schedule(false);
  });
  $('size').addEventListener('change', () => {
    const n = Number($('size').value);
    state.size = [n, n];
    buildViews();
    schedule(false);
  });
  for (const name of state.info.presets) $('preset').add(new Option(name, name));
  $('preset').addEventListener('change', async () => {
    try {
      const rgb = editor.tf.rgb;
      const range = `${rgb[0][0]},${rgb[rgb.length - 1][0]}`;
      const preset = parseParaViewTf(await getText(
          `/api/preset?name=${encodeURIComponent($('preset').value)}&range=${range}`));
      editor.setTf({rgb: preset.rgb, points: editor.tf.points});
      await tfChanged('commit');
    } catch (e) {
      showError(e);
    }
  });
  $('log').addEventListener('change', () => {
    editor.log = $('log').checked;
    editor.draw();
  });
  loadAndSave('tf', '/api/tf', 'tf.json', applyTfText);
  $('png-save').addEventListener('click', () => {
    const v = state.views.get('main');
    if (v.shown && v.shown.kind === 'full') pngOf(v).then((png) => download(png, `udvr-${state.model}.png`));
  });
  $('reset').addEventListener('click', () => {
    state.camera = {...HOME};
    schedule(false);
  });
  window.addEventListener('resize', layoutViews);
  if (state.info.tf2) await startTf2();
  editor.setTf(parseParaViewTf(await getText('/api/tf')));
  editor.setHistogram(await getJson('/api/histogram', {bins: 128}));
  buildViews();
  schedule(false);
}

// For tests and the benchmark: whether every view shows the full frame of the current state.
function idle() {
  if (!state.info || !state.views.size || state.posters.some((p) => p.busy) || state.probing ||
      state.estimating)
    return false;
  const c = cameraParams();
  for (const v of state.views.values()) {
    if (v.pending || v.inFlight.size || !v.shown || v.shown.kind !== 'full') return false;
    const q = JSON.parse(v.shown.query);
    if (q.azimuth !== c.azimuth || q.elevation !== c.elevation || q.zoom !== c.zoom ||
        q.size !== sizeText() || q.model !== v.params.model)
      return false;
  }
  return true;
}

// The PNG `udvr render` writes of the view's shown full frame (the server keeps the frame).
async function pngOf(v) {
  const params = {...JSON.parse(v.shown.query), channel: `png-${v.channel}`.slice(0, 32), page: PAGE};
  return new Blob([(await getRender(params)).bytes], {type: 'image/png'});
}

async function pngBase64(channel) {
  const bytes = new Uint8Array(await (await pngOf(state.views.get(channel))).arrayBuffer());
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

window.udvr = {state, idle, pngBase64, cameraParams, editor, editor2};
start().catch(showError);
