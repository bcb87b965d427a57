// femto view: the page. It keeps one camera state (the JSON of docs/view.md), sends it on
// the WebSocket /ws whenever it changes and the frame before has arrived, and draws the
// frames that come back; a frame older than the one on screen is never drawn.
//
// - The light curve under the time slider is the current view's own (POST /api/curve),
//   asked for again whenever the camera, its velocity or the picture changes; when the
//   time leaves the new lit range, the cursor follows the light.
// - Play advances world time over the view's lit range and loops; a camera with a speed
//   travels along its velocity from where Play found it, never closer to the geometry than
//   the server's margin, and comes back to that point at each loop. A path (loaded, or the
//   keyframes previewed) plays as that path.
// - The state lives in the URL fragment (#s=...), so a reload or a bookmark keeps it. The
//   keyframes are this tab's own (sessionStorage).
// The server let this page in by the token of its URL and set a cookie (HttpOnly,
// SameSite=Strict) that the page's requests and WebSocket carry from then on; the token is
// taken out of the address bar so that a reload, a bookmark or a screenshot does not show it.
'use strict';

if (new URLSearchParams(location.search).has('token')) {
  history.replaceState(null, '', location.pathname + location.hash);
}

const C_M_PER_PS = 2.99792458e-4;
const REDUCED_SCALE = 0.5;  // frame scale while moving, when full frames are too slow
const FULL_FRAME_MS = 40;   // full-size frames while moving when they arrive within this
const SLOW_IN_A_ROW = 2;    // full frames over FULL_FRAME_MS in a row that make moving frames reduced
const REPROBE_MS = 1000;    // while moving on reduced frames, a full one this often to measure again
const SETTLE_MS = 150;      // full resolution this long after the last movement
const CURVE_DELAY_MS = 200; // a new light curve this long after the camera stops changing
const FADE = 0.05;          // Play loops when the lit pixels fall under this share of the loop's most

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const ctx = canvas.getContext('2d');
const draw = femtoDraw;

let info = null;
let state = null;
let curve = null;            // the light curve of the view on screen (/api/curve)
let curveKey = null;         // the state (without its time) that `curve` describes
let curveBusy = false, curveTimer = null;
let worldDirection = null;   // beta's direction when it is fixed in the world
let tau = null;              // proper time elapsed since Play was pressed, ps
let socket = null, gone = false;
let seq = 0, shownSeq = 0, framesShown = 0;
let inFlight = false, dirty = false, moving = false, settleTimer = null;
let sentAt = 0, fullFrameMs = 0, slowFullFrames = 0, lastSentScale = 1, fullSentAt = 0;
let playing = false, loop = null, loadedFrames = null, loadedIndex = 0;
let lastHud = null, lastError = null, fpsTimes = [];
let framesDecoded = 0, bytesReceived = 0, litFramesShown = 0;  // for tools/bench_view_browser.py
let jpegQuality = null;      // null: the server's default
let keyframes = [];          // this page's keyframes (states)
let probe = null;            // the open probe: {pixel, data}
let lastSave = null;         // the last still or video saved: {name, bytes, hash}
let videoFramesSeen = 0;     // the most frames done that the video's progress showed
const KEYFRAMES_KEY = 'femto-view-keyframes';  // sessionStorage: this tab only

// --- vectors and rotations (rows of world_from_camera; columns are camera x, y, z) ---
const col = (R, j) => [R[0][j], R[1][j], R[2][j]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const norm = (a) => Math.hypot(a[0], a[1], a[2]);
const unit = (a) => scale(a, 1 / norm(a));
const copy = (v) => JSON.parse(JSON.stringify(v));
function rotate(v, axis, angle) {  // Rodrigues, axis a unit vector
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross(axis, v), s)), scale(axis, dot(axis, v) * (1 - c)));
}
function fromColumns(x, y, z) {
  return [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]];
}
// Turn the camera by `angle` about the world axis `axis`, keeping the matrix a rotation.
function turn(axis, angle) {
  const R = state.world_from_camera;
  const z = unit(rotate(col(R, 2), axis, angle));
  let x = rotate(col(R, 0), axis, angle);
  x = unit(add(x, scale(z, -dot(x, z))));
  state.world_from_camera = fromColumns(x, cross(z, x), z);
}
const forward = () => col(state.world_from_camera, 2);
const right = () => col(state.world_from_camera, 0);
const gamma = (b) => 1 / Math.sqrt(1 - dot(b, b));

// --- the state and the controls ---
function speed() { return parseFloat($('beta').value); }
function updateBeta() {
  const dir = $('direction').value === 'world' ? (worldDirection || forward()) : forward();
  state.beta = scale(unit(dir), speed());
}

// A number for display: `digits` significant digits, no trailing noise.
const round = (x, digits = 4) => Number(Number(x).toPrecision(digits)).toString();

function syncControls() {
  $('vfov').value = state.vfov_deg;
  const size = `${state.width}x${state.height}`;
  if (![...$('size').options].some((o) => o.value === size)) {
    const o = new Option(`${state.width} x ${state.height}`, size);
    $('size').add(o, $('size').options[$('size').options.length - 1]);
  }
  $('size').value = size;
  const b = Math.min(norm(state.beta), 0.999);
  $('beta').value = b;
  $('beta-num').value = b.toFixed(3);
  $('time').value = state.t_world_ps;
  $('dtau').value = round(state.dtau_ps);
  $('spin-axis').value = state.rotation ? state.rotation.axis : '';
  if (state.rotation) $('spin-beta').value = state.rotation.beta_edge;
  for (const box of document.querySelectorAll('[data-effect]')) box.checked = state.effects[box.dataset.effect];
  $('view-kind').value = state.view;
  $('radiometry').value = state.radiometry;
  $('exposure').value = Math.log2(state.exposure);
  $('laser').value = round(state.laser_nm, 6);
  $('dark-marks').checked = !!state.dark_marks;
  $('false-colour').checked = !!state.false_colour;
  showOutputs();
}

// Controls that change nothing in the current mode are disabled, with the reason.
function enableControls() {
  const noSpin = !state.rotation;
  const iso = state.view === 'isochrones';
  const still = (el, off, why) => { el.disabled = off; el.closest('label').title = off ? why : ''; };
  still($('spin-beta'), noSpin, 'no sensor rotation: choose roll, yaw or pitch');
  still($('direction'), speed() === 0, 'the camera is at rest (beta 0)');
  still($('exposure'), iso, 'isochrones are drawn in fixed colours');
  still($('radiometry'), iso, 'isochrones are drawn in fixed colours');
  still($('laser'), iso, 'isochrones are drawn in fixed colours');
  const effect = (name) => document.querySelector(`[data-effect="${name}"]`);
  effect('rotation').disabled = noSpin;
  for (const name of ['doppler', 'searchlight', 'dilation']) effect(name).disabled = iso;
}

function timeRange() {
  const r = curve && curve.time_range_ps[1] > curve.time_range_ps[0] ? curve.time_range_ps : info.time_range_ps;
  return [Math.min(r[0], state.t_world_ps), Math.max(r[1], state.t_world_ps)];
}

function showOutputs() {
  $('vfov-out').textContent = `${(+$('vfov').value).toFixed(1)} deg`;
  $('spin-beta-out').textContent = (+$('spin-beta').value).toFixed(2);
  $('time-out').textContent = `${(+state.t_world_ps).toFixed(1)} ps`;
  $('exposure-out').textContent = `${(+$('exposure').value).toFixed(2)}`;
  const [t0, t1] = timeRange();
  Object.assign($('time'), { min: t0, max: t1, step: 'any' });
  $('time').value = state.t_world_ps;
  enableControls();
  draw.lightCurve($('light-curve'), curve, [t0, t1], state.t_world_ps);
  showHud();
}

// The status line says one thing about the latest action; the next action clears it.
function setStatus(text) { $('status').textContent = text; $('status').title = text; }

// The state changed. `isMovement`: by a drag, a key or a slider (reduced frames while it
// goes on). `note`: the effect note of this action (any other action clears the note).
function changed(isMovement, note = '') {
  if (isMovement) {
    moving = true;
    clearTimeout(settleTimer);
    settleTimer = setTimeout(() => { moving = false; if (lastSentScale < 1) { dirty = true; pump(); } }, SETTLE_MS);
  }
  $('effect-note').textContent = note;
  if (!lastError) setStatus('');
  showOutputs();
  saveFragment();
  if (!playing) askCurve();
  if (probe) askProbe();
  dirty = true;
  pump();
}

// --- the URL fragment: the state, so that a reload or a bookmark keeps the view ---
let fragmentTimer = null;
function saveFragment() {
  clearTimeout(fragmentTimer);
  fragmentTimer = setTimeout(() => {
    history.replaceState(null, '', `${location.pathname}#s=${encodeURIComponent(JSON.stringify(state))}`);
  }, 250);
}

function stateOfFragment() {
  const m = location.hash.match(/^#s=(.*)$/);
  if (!m) return null;
  try {
    const s = JSON.parse(decodeURIComponent(m[1]));
    // Fields the fragment lacks come from the capture view; it holds nothing else.
    const merged = Object.assign(copy(info.capture_state), s);
    for (const k of Object.keys(merged)) if (!(k in info.capture_state)) delete merged[k];
    return merged;
  } catch (e) {
    return null;
  }
}

// --- the light curve of the current view ---
function keyOf(s) { const k = copy(s); delete k.t_world_ps; return JSON.stringify(k); }

function askCurve() {
  if (keyOf(state) === curveKey) return;
  clearTimeout(curveTimer);
  curveTimer = setTimeout(fetchCurve, CURVE_DELAY_MS);
}

async function fetchCurve() {
  if (curveBusy) { curveTimer = setTimeout(fetchCurve, CURVE_DELAY_MS); return; }
  const key = keyOf(state);
  if (key === curveKey) return;
  curveBusy = true;
  try {
    const sent = copy(state);
    const c = await api('POST', '/api/curve', JSON.stringify(sent));
    if (keyOf(state) === key) useCurve(c, key);
  } catch (e) {
    curveKey = key;  // refused (the status line says why): not asked again for this view
  }
  curveBusy = false;
  if (keyOf(state) !== curveKey && !playing) askCurve();
}

// A new curve for the view on screen: when the time is outside its lit range, the cursor
// follows the light (by as much as the lit range moved, else to its brightest moment).
function useCurve(c, key) {
  const old = curve;
  curve = c; curveKey = key;
  const lit = c.lit_range_ps;
  const t = state.t_world_ps;
  if (lit && !playing && (t < lit[0] || t > lit[1])) {
    let next = c.peak_ps;
    if (old && old.lit_range_ps) {
      const moved = t + (lit[0] - old.lit_range_ps[0]);
      if (moved >= lit[0] && moved <= lit[1]) next = moved;
    }
    state.t_world_ps = next;
    dirty = true;
    saveFragment();
    pump();
  }
  showOutputs();
  if (lastHud) explainDark(lastHud);
}

// --- the frame stream ---
function connect() {
  socket = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => { gone = false; setStatus(''); inFlight = false; dirty = true; pump(); };
  socket.onclose = async () => {
    inFlight = false;
    // A server restarted since this tab opened has a new token: this tab's cookie no
    // longer lets it in, and only the new URL (with its token) will.
    let restarted = false;
    try { restarted = (await fetch('/api/info', { credentials: 'same-origin' })).status === 403; } catch (e) { /* down */ }
    gone = true;
    setStatus(restarted
      ? 'femto view was restarted: this tab belongs to its earlier run. Open the URL with ?token= that it printed.'
      : 'disconnected from femto view; retrying');
    setTimeout(connect, restarted ? 5000 : 1000);
  };
  socket.onmessage = (event) => {
    inFlight = false;
    if (typeof event.data === 'string') {
      const refusal = JSON.parse(event.data);
      lastError = refusal.error;
      setStatus(refusal.error);
      stopPlay();
    } else {
      receive(event.data);
    }
    pump();
  };
}

function receive(buf) {
  bytesReceived += buf.byteLength;
  const n = new DataView(buf).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  if (header.hud.width === state.width) {
    fullFrameMs = performance.now() - sentAt;
    slowFullFrames = fullFrameMs > FULL_FRAME_MS ? slowFullFrames + 1 : 0;
  }
  if (lastError) { lastError = null; setStatus(''); }
  // Playing straight, a dark frame is not shown: before the light arrives it is skipped
  // (a whole loop of them is shown, with its explanation), and once the light has left the
  // view before the loop's end (the camera moved: under FADE of the loop's brightest), the
  // loop starts again.
  const lit = header.hud.lit_fraction;
  if (playing && loop) {
    if (loop.litSeen && lit < FADE * loop.maxLit) { restartLoop(); advance(); return; }
    if (lit === 0 && ++loop.dark <= loop.frames) { advance(); return; }
    if (lit > 0) { loop.litSeen = true; loop.dark = 0; loop.maxLit = Math.max(loop.maxLit, lit); }
  }
  // Decoded off the main thread; drawn when ready, unless a newer frame was drawn first.
  createImageBitmap(new Blob([new Uint8Array(buf, 4 + n)], { type: 'image/jpeg' }))
    .then((bitmap) => { framesDecoded += 1; drawFrame(header, bitmap); });
  if (playing) advance();
}

function pump() {
  if (!dirty || inFlight || !socket || socket.readyState !== WebSocket.OPEN) return;
  // Reduced frames only while moving and only when full frames are too slow to follow: the
  // last SLOW_IN_A_ROW of them took over FULL_FRAME_MS (one slow frame, the first after a new
  // light curve for example, or a busy moment of the machine, does not reduce the next
  // second's frames). The measure is taken again with a full frame every REPROBE_MS.
  const now = performance.now();
  const slow = slowFullFrames >= SLOW_IN_A_ROW && now - fullSentAt < REPROBE_MS;
  const s = (moving && !playing && slow) ? REDUCED_SCALE : 1;
  if (s === 1) fullSentAt = now;
  seq += 1;
  socket.send(JSON.stringify(jpegQuality ? { seq, scale: s, quality: jpegQuality, state } : { seq, scale: s, state }));
  sentAt = performance.now();
  lastSentScale = s;
  inFlight = true;
  dirty = false;
}

function drawFrame(header, bitmap) {
  if (header.seq <= shownSeq) { bitmap.close(); return; }  // a newer frame is on screen
  shownSeq = header.seq;
  framesShown += 1;
  if (header.hud.lit_fraction > 0) litFramesShown += 1;
  if (canvas.width !== state.width || canvas.height !== state.height) {
    canvas.width = state.width; canvas.height = state.height;
  }
  ctx.imageSmoothingEnabled = true;
  ctx.drawImage(bitmap, 0, 0, canvas.width, canvas.height);
  bitmap.close();
  lastHud = header.hud;
  fpsTimes.push(performance.now());
  showHud();
  showLegend(header.hud);
  explainDark(header.hud);
  draw.probeMark($('marks'), probe && probe.pixel, state.width, state.height);
}

function framesPerSecond() {
  const now = performance.now();
  while (fpsTimes.length && now - fpsTimes[0] > 1000) fpsTimes.shift();
  return fpsTimes.length;
}

// The heads-up line: the state's own numbers (what the sliders say), the frame's Doppler
// range, where the camera is and where it looks, and the frame rate.
function showHud() {
  const h = lastHud;
  if (!h || !state) return;
  const fps = framesPerSecond();
  const b = norm(state.beta);
  const p = state.position_m.map((v) => v.toFixed(2)).join(', ');
  const f = forward();
  const up = info.up;
  const heading = Math.atan2(dot(f, right0()), dot(f, ahead0())) * 180 / Math.PI;
  const elevation = Math.asin(Math.max(-1, Math.min(1, dot(f, up)))) * 180 / Math.PI;
  const reduced = h.width !== state.width ? `  reduced ${h.width}x${h.height} while moving (full frames ${fullFrameMs.toFixed(0)} ms)` : '';
  $('hud').textContent =
    `\u03b2 ${b.toFixed(3)} \u03b3 ${gamma(state.beta).toFixed(3)} D ${h.doppler_min.toFixed(2)}..${h.doppler_max.toFixed(2)}` +
    `  t ${state.t_world_ps.toFixed(1)} ps  \u03c4 ${tau === null ? '-' : tau.toFixed(0) + ' ps'}` +
    `  at (${p}) m, heading ${heading.toFixed(0)}\u00b0 elev. ${elevation.toFixed(0)}\u00b0` +
    `  ${state.width}x${state.height} ${fps ? fps + ' fps' : 'idle'} ${h.render_ms.toFixed(0)} ms${reduced}`;
}
// The capture camera's forward and right directions flattened to the ground: heading 0 is
// the capture camera's direction.
function ahead0() { const f = col(info.capture_state.world_from_camera, 2); return unit(add(f, scale(info.up, -dot(f, info.up)))); }
function right0() { return cross(info.up, ahead0()).map((v) => -v); }

// Why the frame is dark, on the picture, whenever it is.
function explainDark(h) {
  const why = darkReason(h);
  $('dark-why').hidden = !why;
  $('dark-why').textContent = why || '';
}

function darkReason(h) {
  if (lastError || h.lit_fraction > 0 || state.view === 'isochrones') return null;
  if (curve && curve.note) return curve.note;
  if (!state.effects.unwarp && state.view === 'transient') {
    return 'No light: with unwarp off each pixel shows the light emitted at the reception time itself ' +
      '(no flight time), after the light at the camera has gone. Move the time earlier.';
  }
  const t = state.t_world_ps;
  const lit = curve && curve.lit_range_ps;
  if (!lit) return 'No light at this time; measuring where this view\'s light is\u2026';
  const range = `${lit[0].toFixed(0)}-${lit[1].toFixed(0)} ps, shaded under the slider`;
  if (t < lit[0]) return `No light yet at ${t.toFixed(0)} ps: this view receives the light at ${range}.`;
  if (t > lit[1]) return `The light has passed at ${t.toFixed(0)} ps: this view receives it at ${range}.`;
  return `No light reaches this view at ${t.toFixed(0)} ps (a gap in its light, ${range}); ` +
    'move the time, or raise the exposure.';
}

function showLegend(h) {
  const iso = h.isochrones;
  $('spectrum-legend').hidden = !!iso;
  $('iso-legend').hidden = !iso;
  $('dark-legend').style.visibility = (state.dark_marks && !iso) ? 'visible' : 'hidden';
  if (iso) draw.isochrones($('iso-bar'), $('iso-text'), iso, state.t_world_ps);
  else draw.spectrum($('spectrum'), $('legend-text'), info, h, state.effects.doppler, state.false_colour);
}

// What each toggle changes, shown when it is toggled.
const EFFECT_NOTES = {
  unwarp: 'unwarp: takes each pixel at its emission time (reception minus flight time); off shows the light emitted at the reception time.',
  aberration: 'aberration: bends the view with the camera velocity; no change at beta 0.',
  doppler: 'doppler: colours by the shifted wavelength; off draws every pixel at the laser colour. No change at beta 0.',
  searchlight: 'searchlight: brightness times the Doppler factor; no change at beta 0.',
  dilation: 'dilation: changes how fast world time plays during Play (gamma per frame), not a still.',
  rotation: 'rotation: the sensor rotation of the Velocity section; nothing without one.',
};

// --- play ---
function startPlay() {
  if (loadedFrames) {
    if (loadedIndex >= loadedFrames.length - 1) loadedIndex = -1;
    tau = 0; playing = true; loop = null;
  } else {
    const lit = curve && curve.lit_range_ps;
    if (!lit) { setStatus(`nothing to play: ${(curve && curve.note) || 'this view receives no light'}`); return; }
    // Each loop runs over the lit range from its first lit sample (the range reaches half a
    // sample's spacing before it); the first starts where Play found the camera when that
    // is inside the range. Every loop starts from the place where Play found the camera and
    // ends before the camera comes within a key step of the geometry ahead.
    const now = state.t_world_ps;
    const first = curve.t_ps.find((t) => t >= lit[0]) ?? lit[0];
    const b = norm(state.beta);
    const room = (b > 0 && curve.travel_m !== null) ? curve.travel_m / (b * C_M_PER_PS) : Infinity;
    const step = (state.effects.dilation ? gamma(state.beta) : 1) * state.dtau_ps;
    loop = { position: state.position_m.slice(), t0: first, start: first, room, end: lit[1],
             litSeen: false, dark: 0, maxLit: 0, frames: Math.ceil((lit[1] - first) / step) + 1 };
    restartLoop();
    if (now > first && now < lit[1]) { loop.start = now; state.t_world_ps = now - step; }
    playing = true; tau = 0;
  }
  $('play').textContent = 'Pause';
  advance();
  changed(false);
}

function stopPlay() {
  if (!playing) return;
  playing = false; loop = null;
  $('play').textContent = 'Play';
  askCurve();
}

// Back to the start of the loop: the time and the place where Play found the camera.
function restartLoop() {
  state.t_world_ps = loop.t0 - (state.effects.dilation ? gamma(state.beta) : 1) * state.dtau_ps;
  state.position_m = loop.position.slice();
  loop.start = loop.t0;
  loop.litSeen = false;
  loop.dark = 0;
  dirty = true;
}

// One frame interval of proper time along the camera's straight, uniform motion, or the
// next frame of a path.
function advance() {
  if (loadedFrames) {
    loadedIndex += 1;
    if (loadedIndex >= loadedFrames.length) { stopPlay(); return; }
    state = copy(loadedFrames[loadedIndex]);
    tau += state.dtau_ps;
    syncControls();
  } else {
    const g = state.effects.dilation ? gamma(state.beta) : 1;
    let t = state.t_world_ps + g * state.dtau_ps;
    if (t > Math.min(loop.end, loop.start + loop.room)) { restartLoop(); t = loop.t0; }
    state.t_world_ps = t;
    state.position_m = add(loop.position, scale(state.beta, C_M_PER_PS * (t - loop.start)));
    tau += state.dtau_ps;
    showOutputs();
  }
  saveFragment();
  dirty = true;
}

// --- the pixel probe ---
let probeTimer = null;
function askProbe() {
  clearTimeout(probeTimer);
  probeTimer = setTimeout(fetchProbe, playing ? 400 : 120);
}

async function fetchProbe() {
  if (!probe) return;
  const [i, j] = probe.pixel;
  const [t0, t1] = timeRange();
  try {
    probe.data = await api('POST', `/api/probe?x=${i}&y=${j}&t0=${t0}&t1=${t1}`, JSON.stringify(state));
    showProbe();
  } catch (e) { /* shown in the status line */ }
}

function openProbe(i, j) {
  probe = { pixel: [i, j], data: null };
  $('probe').hidden = false;
  $('probe-pixel').textContent = `pixel ${i}, ${j}`;
  draw.probeMark($('marks'), probe.pixel, state.width, state.height);
  fetchProbe();
}

function showProbe() {
  const p = probe.data;
  const v = (x, d = 3) => (x === null || x === undefined) ? '-' : Number(x).toFixed(d);
  const lines = [
    `<b>${p.kind_text}</b>`,
    p.point_m ? `point (${p.point_m.map((x) => x.toFixed(3)).join(', ')}) m, ${v(p.distance_m)} m away` : 'no surface',
    `Doppler D ${v(p.doppler, 4)}, received ${v(p.lambda_nm, 1)} nm`,
    `received at ${v(p.t_receive_ps, 1)} ps, emitted at ${v(p.t_emit_ps, 1)} ps (world)`,
    p.capture_pixel ? `capture pixel x ${p.capture_pixel[0]}, y ${p.capture_pixel[1]}` : 'no capture pixel records it',
  ];
  $('probe-text').innerHTML = lines.join('<br>');
  $('probe').dataset.kind = p.kind;
  draw.probePlot($('probe-plot'), p, state.t_world_ps);
}

// --- saving ---
// FNV-1a of the bytes saved, for the browser test to compare with the server's.
function fnv1a(bytes) {
  let h = 0x811c9dc5;
  for (const b of new Uint8Array(bytes)) h = Math.imul(h ^ b, 0x01000193) >>> 0;
  return h;
}

function download(bytes, name, type) {
  lastSave = { name, bytes: bytes.byteLength, hash: fnv1a(bytes) };
  const link = $('save-link');
  link.href = URL.createObjectURL(new Blob([bytes], { type }));
  link.download = name;
  link.textContent = `download ${name}`;
  link.hidden = false;
  link.click();
}

async function saveStill() {
  const r = await rawApi('POST', '/api/still', JSON.stringify(state));
  if (!r) return;
  const bytes = await r.arrayBuffer();
  download(bytes, `femto-view-${state.t_world_ps.toFixed(0)}ps.png`, 'image/png');
  setStatus(`saved a ${state.width} x ${state.height} PNG still: femto render of this state writes the same bytes`);
}

async function saveVideo() {
  if (!keyframes.length) { setStatus('Save video renders the keyframes\' path: add keyframes first'); return; }
  const format = $('video-format').value;
  const bar = $('video-progress');
  bar.hidden = false; bar.removeAttribute('value');
  const poll = setInterval(async () => {
    try {
      const s = await api('GET', '/api/video');
      if (s.frames) {
        bar.max = s.frames; bar.value = s.frames_done;
        videoFramesSeen = Math.max(videoFramesSeen, s.frames_done);
        setStatus(`rendering the video: frame ${s.frames_done} of ${s.frames}`);
      }
    } catch (e) { /* next poll */ }
  }, 250);
  try {
    const r = await rawApi('POST', `/api/video?format=${format}`, JSON.stringify(keyframes));
    if (r) {
      const bytes = await r.arrayBuffer();
      download(bytes, `femto-path.${format}`, format === 'gif' ? 'image/gif' : 'video/mp4');
      setStatus(`saved the keyframes' path as ${format.toUpperCase()} (${(bytes.byteLength / 1024).toFixed(0)} kB)`);
    }
  } finally {
    clearInterval(poll);
    bar.hidden = true;
  }
}

// --- input ---
// Keys fly the camera wherever focus is, except in a text field; a slider takes keys only
// when it was reached with Tab.
let tabbedTo = null;
function flies(target) {
  if (!target || target === document.body) return true;
  if (target.tagName === 'TEXTAREA' || target.tagName === 'SELECT') return false;
  if (target.tagName === 'INPUT') {
    if (target.type === 'range') return target !== tabbedTo;
    return target.type === 'checkbox' || target.type === 'button' || target.type === 'file';
  }
  return true;
}

function key(e) {
  if (e.ctrlKey || e.metaKey || e.altKey || !state) return;
  if (!flies(e.target)) return;
  if (e.code === 'Space') { e.preventDefault(); if (playing) stopPlay(); else startPlay(); return; }
  const step = info.move_step_m;
  const moves = {
    KeyW: forward(), ArrowUp: forward(), KeyS: scale(forward(), -1), ArrowDown: scale(forward(), -1),
    KeyD: right(), ArrowRight: right(), KeyA: scale(right(), -1), ArrowLeft: scale(right(), -1),
    KeyE: info.up, KeyQ: scale(info.up, -1),
  };
  const dir = moves[e.code];
  if (!dir) return;
  e.preventDefault();
  state.position_m = add(state.position_m, scale(dir, step));
  loadedFrames = null;
  if (loop) loop.position = add(loop.position, scale(dir, step));
  changed(true);
}

function fitSize() {
  const box = $('picture');
  const w = Math.floor(Math.min(box.clientWidth - 4, info.max_side) / 8) * 8;
  const h = Math.floor(Math.min(box.clientHeight - 4, info.max_side) / 8) * 8;
  return [Math.max(w, 64), Math.max(h, 48)];
}

function bindTime() {
  $('time').oninput = () => { state.t_world_ps = +$('time').value; changed(true); };
  // The light curve is a scrubber too: a press or a drag on it sets the time.
  const curveCanvas = $('light-curve');
  const scrub = (e) => {
    const r = curveCanvas.getBoundingClientRect();
    const [t0, t1] = timeRange();
    state.t_world_ps = t0 + Math.max(0, Math.min(1, (e.clientX - r.left) / r.width)) * (t1 - t0);
    changed(true);
  };
  curveCanvas.addEventListener('pointerdown', (e) => { curveCanvas.setPointerCapture(e.pointerId); scrub(e); });
  curveCanvas.addEventListener('pointermove', (e) => { if (curveCanvas.hasPointerCapture(e.pointerId)) scrub(e); });
  $('dtau').onchange = () => {
    const d = +$('dtau').value;
    if (d > 0 && Number.isFinite(d)) { state.dtau_ps = d; changed(false); } else {
      setStatus(`interval: ${$('dtau').value} is not a positive number of ps`);
      $('dtau').value = round(state.dtau_ps);
    }
  };
  $('play').onclick = () => { if (playing) stopPlay(); else startPlay(); };
}

function bindVelocity() {
  $('beta').oninput = () => { $('beta-num').value = (+$('beta').value).toFixed(3); updateBeta(); changed(true); };
  $('beta-num').onchange = () => {
    const b = +$('beta-num').value;
    if (!(b >= 0 && b < 1)) {
      setStatus(`beta: ${$('beta-num').value} must be at least 0 and below 1`);
      $('beta-num').value = (+$('beta').value).toFixed(3);
      return;
    }
    $('beta').value = b;
    state.beta = scale(unit($('direction').value === 'world' ? (worldDirection || forward()) : forward()), b);
    changed(false);
  };
  $('direction').onchange = () => {
    worldDirection = $('direction').value === 'world' ? forward() : null;
    updateBeta(); changed(false);
  };
  const spin = () => {
    const axis = $('spin-axis').value;
    state.rotation = axis ? { axis, beta_edge: +$('spin-beta').value } : null;
    changed(true);
  };
  $('spin-axis').onchange = spin;
  $('spin-beta').oninput = spin;
}

function bindPicture() {
  for (const box of document.querySelectorAll('[data-effect]')) {
    box.onchange = () => {
      state.effects[box.dataset.effect] = box.checked;
      changed(false, EFFECT_NOTES[box.dataset.effect]);
    };
  }
  $('view-kind').onchange = () => { state.view = $('view-kind').value; changed(false); };
  $('radiometry').onchange = () => { state.radiometry = $('radiometry').value; changed(false); };
  $('exposure').oninput = () => { state.exposure = Math.pow(2, +$('exposure').value); changed(true); };
  $('dark-marks').onchange = () => { state.dark_marks = $('dark-marks').checked; changed(false); };
  $('false-colour').onchange = () => { state.false_colour = $('false-colour').checked; changed(false); };
  $('laser').onchange = () => {
    const l = +$('laser').value;
    if (!(l > 0 && l <= 1e6) || $('laser').value.trim() === '') {
      setStatus(`laser: ${$('laser').value} nm is not a wavelength: give one above 0 and at most 1e6 nm`);
      $('laser').value = round(state.laser_nm, 6);
      return;
    }
    state.laser_nm = l; changed(false);
  };
  $('vfov').oninput = () => { state.vfov_deg = +$('vfov').value; changed(true); };
  $('size').onchange = () => {
    const [w, h] = $('size').value === 'fit' ? fitSize() : $('size').value.split('x').map(Number);
    state.width = w; state.height = h;
    syncControls(); changed(false);
  };
}

function bindPaths() {
  $('add-keyframe').onclick = () => {
    keyframes.push(copy(state));
    saveKeyframes(); showKeyframes();
  };
  $('clear-keyframes').onclick = () => { keyframes = []; saveKeyframes(); showKeyframes(); };
  $('preview-path').onclick = previewPath;
  $('export-path').onclick = exportPath;
  $('save-still').onclick = saveStill;
  $('save-video').onclick = saveVideo;
  $('load-path').onchange = async () => {
    const file = $('load-path').files[0];
    if (!file) return;
    try {
      playFrames((await api('POST', '/api/path', await file.text(), 'application/toml')).frames,
        `loaded ${file.name}`, false);
    } catch (e) { /* shown in the status line */ }
  };
}

function bindLook() {
  // Drag to look around; a click (no drag) probes the pixel under the pointer.
  let drag = null, travelled = 0;
  canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; travelled = 0; canvas.setPointerCapture(e.pointerId); canvas.focus(); });
  canvas.addEventListener('pointerup', (e) => {
    if (drag && travelled < 3) {
      const r = canvas.getBoundingClientRect();
      const i = Math.floor((e.clientX - r.left) / r.width * state.width);
      const j = Math.floor((e.clientY - r.top) / r.height * state.height);
      if (i >= 0 && j >= 0 && i < state.width && j < state.height) openProbe(i, j);
    }
    drag = null;
  });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const k = (state.vfov_deg * Math.PI / 180) / canvas.clientHeight;
    const [dx, dy] = [e.clientX - drag[0], e.clientY - drag[1]];
    travelled += Math.abs(dx) + Math.abs(dy);
    if (travelled < 3) return;
    drag = [e.clientX, e.clientY];
    turn(info.up, -dx * k);
    turn(right(), -dy * k);
    loadedFrames = null;
    updateBeta(); changed(true);
  });
  $('probe-close').onclick = () => { probe = null; $('probe').hidden = true; draw.probeMark($('marks'), null, state.width, state.height); };
}

function bind() {
  document.addEventListener('keydown', (e) => { if (e.key === 'Tab') tabbedTo = 'next'; key(e); });
  document.addEventListener('focusin', (e) => { tabbedTo = tabbedTo === 'next' ? e.target : null; });
  document.addEventListener('pointerdown', () => { tabbedTo = null; });
  // A slider, button or list let go of gives focus back to the page, so keys fly at once.
  const release = (e) => {
    const t = e.target;
    if (t.matches && t.matches('input[type=range], input[type=checkbox], button, select') && t !== tabbedTo) t.blur();
  };
  document.addEventListener('pointerup', release);
  document.addEventListener('change', release);
  document.addEventListener('click', (e) => { if (e.target.matches && e.target.matches('button')) e.target.blur(); });
  $('reset').onclick = () => {
    stopPlay();
    state = copy(info.capture_state);
    worldDirection = null; tau = null; loadedFrames = null;
    curve = info.light_curve; curveKey = keyOf(state);
    syncControls(); changed(false);
  };
  bindTime(); bindVelocity(); bindPicture(); bindPaths(); bindLook();
  // The frame rate says "idle" when nothing has been drawn for a second.
  setInterval(showHud, 500);
}

// The server refuses a POST that does not say what it sends (docs/view.md, "Access").
async function rawApi(method, url, body, contentType = 'application/json') {
  const headers = body === undefined ? {} : { 'Content-Type': contentType };
  const r = await fetch(url, { method, body, headers, credentials: 'same-origin' });
  if (!r.ok) { setStatus((await r.text()).trim()); return null; }
  return r;
}

async function api(method, url, body, contentType) {
  const r = await rawApi(method, url, body, contentType);
  if (!r) throw new Error($('status').textContent);
  const type = r.headers.get('Content-Type') || '';
  return type.startsWith('application/json') ? r.json() : r.text();
}

function saveKeyframes() {
  try { sessionStorage.setItem(KEYFRAMES_KEY, JSON.stringify(keyframes)); } catch (e) { /* private mode */ }
}

function loadKeyframes() {
  try { keyframes = JSON.parse(sessionStorage.getItem(KEYFRAMES_KEY) || '[]'); } catch (e) { keyframes = []; }
  if (!Array.isArray(keyframes)) keyframes = [];
}

function showKeyframes() {
  const ol = $('keyframes');
  ol.textContent = '';
  keyframes.forEach((k, i) => {
    const li = document.createElement('li');
    li.textContent = `${k.t_world_ps.toFixed(1)} ps, \u03b2 ${norm(k.beta).toFixed(3)}`;
    const go = document.createElement('button');
    go.textContent = 'Go to';
    go.onclick = () => { stopPlay(); state = copy(k); loadedFrames = null; syncControls(); changed(false); };
    const del = document.createElement('button');
    del.textContent = 'Delete';
    del.onclick = () => { keyframes.splice(i, 1); saveKeyframes(); showKeyframes(); };
    li.append(go, del);
    ol.append(li);
  });
}

// Show the first of `frames` (states): a loaded file (Play plays it), or the keyframes'
// path (`autoplay`: played at once).
function playFrames(frames, what, autoplay) {
  stopPlay();
  loadedFrames = frames; loadedIndex = 0;
  state = copy(loadedFrames[0]); tau = null;
  syncControls(); changed(false);
  setStatus(`${what}: ${loadedFrames.length} frames; ${autoplay ? 'playing' : 'press Play'}`);
  if (autoplay) startPlay();
}

async function previewPath() {
  if (!keyframes.length) { setStatus('Preview path plays the keyframes\' path: add keyframes first'); return; }
  try {
    const text = await api('POST', '/api/path.toml', JSON.stringify(keyframes));
    playFrames((await api('POST', '/api/path', text, 'application/toml')).frames, 'the keyframes\' path', true);
  } catch (e) { /* shown in the status line */ }
}

async function exportPath() {
  try {
    const text = await api('POST', '/api/path.toml', JSON.stringify(keyframes));
    $('path-toml').value = text;
    const link = $('path-download');
    link.href = URL.createObjectURL(new Blob([text], { type: 'application/toml' }));
    link.hidden = false;
    setStatus(`exported ${keyframes.length} keyframes`);
  } catch (e) { /* shown in the status line */ }
}

async function start() {
  info = await api('GET', '/api/info');
  state = copy(info.capture_state);
  curve = info.light_curve; curveKey = keyOf(state);
  const kept = stateOfFragment();
  if (kept) { state = kept; }
  syncControls();
  bind();
  loadKeyframes();
  showKeyframes();
  saveFragment();
  askCurve();
  connect();
}

// For scripts and the browser test: the page's state and what it has shown.
window.femto = {
  get state() { return state; },
  get info() { return info; },
  get curve() { return curve; },
  get shownSeq() { return shownSeq; },
  get framesShown() { return framesShown; },
  get litFramesShown() { return litFramesShown; },
  get framesDecoded() { return framesDecoded; },
  get bytesReceived() { return bytesReceived; },
  get keyframes() { return keyframes; },
  get hud() { return lastHud; },
  get error() { return lastError; },
  get playing() { return playing; },
  get probe() { return probe && probe.data; },
  get lastSave() { return lastSave; },
  get videoFramesSeen() { return videoFramesSeen; },
  get disconnected() { return gone; },
  // JPEG quality of the frames asked for, 1-100 (null: the server's default).
  get quality() { return jpegQuality; },
  set quality(q) { jpegQuality = q; },
  // The frame of the current state is on screen at full size, its light curve is the
  // view's, and nothing is pending.
  get settled() {
    return !dirty && !inFlight && !moving && !playing && lastSentScale === 1 && shownSeq === seq &&
      !curveBusy && keyOf(state) === curveKey;
  },
};

start();
