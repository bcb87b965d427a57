// femto view: the page. It keeps one camera state (the JSON of docs/view.md), sends it on
// the WebSocket /ws whenever it changes and the frame before has arrived, and draws the
// frames that come back; a frame older than the one on screen is never drawn. The
// keyframes are the page's own (sessionStorage: a reload keeps them, another tab does not
// see them).
// The server let this page in by the token of its URL and set a cookie (HttpOnly,
// SameSite=Strict) that the page's requests and WebSocket carry from then on; the token is
// taken out of the address bar so that a reload, a bookmark or a screenshot does not show it.
'use strict';

if (new URLSearchParams(location.search).has('token')) {
  history.replaceState(null, '', location.pathname);
}

const C_M_PER_PS = 2.99792458e-4;
const REDUCED_SCALE = 0.5;  // frame scale while the camera moves
const SETTLE_MS = 150;      // full resolution this long after the last movement

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const ctx = canvas.getContext('2d');

let info = null;
let state = null;
let worldDirection = null;  // beta's direction when it is fixed in the world
let tau = null;             // proper time elapsed since Play was pressed, ps (null: not playing yet)
let socket = null;
let seq = 0, shownSeq = 0, framesShown = 0;
let inFlight = false, dirty = false, moving = false, settleTimer = null;
let lastSentScale = 1;
let playing = false, loadedFrames = null, loadedIndex = 0;
let lastHud = null, lastError = null, fpsTimes = [];
let framesDecoded = 0, bytesReceived = 0;  // counters for tools/bench_view_browser.py
let jpegQuality = null;                    // null: the server's default
let keyframes = [];                        // this page's keyframes (states)
const KEYFRAMES_KEY = 'femto-view-keyframes';  // sessionStorage: this tab only

// --- vectors and rotations (rows of world_from_camera; columns are camera x, y, z) ---
const col = (R, j) => [R[0][j], R[1][j], R[2][j]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const norm = (a) => Math.hypot(a[0], a[1], a[2]);
const unit = (a) => scale(a, 1 / norm(a));
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
  $('size').value = `${state.width}x${state.height}`;
  if (![...$('size').options].some((o) => o.value === $('size').value)) {
    const o = new Option(`${state.width} x ${state.height}`, `${state.width}x${state.height}`);
    $('size').add(o); $('size').value = o.value;
  }
  $('beta').value = Math.min(norm(state.beta), 0.999);
  $('time').value = state.t_world_ps;
  $('dtau').value = round(state.dtau_ps);
  $('spin-axis').value = state.rotation ? state.rotation.axis : '';
  if (state.rotation) $('spin-beta').value = state.rotation.beta_edge;
  for (const box of document.querySelectorAll('[data-effect]')) box.checked = state.effects[box.dataset.effect];
  $('view-kind').value = state.view;
  $('radiometry').value = state.radiometry;
  $('exposure').value = Math.log2(state.exposure);
  $('laser').value = round(state.laser_nm, 6);
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

function showOutputs() {
  $('vfov-out').textContent = `${(+$('vfov').value).toFixed(1)} deg`;
  $('beta-out').textContent = (+$('beta').value).toFixed(3);
  $('spin-beta-out').textContent = (+$('spin-beta').value).toFixed(2);
  $('time-out').textContent = `${(+state.t_world_ps).toFixed(1)} ps`;
  $('exposure-out').textContent = `${(+$('exposure').value).toFixed(2)}`;
  enableControls();
  drawLightCurve();
}

// The status line says one thing about the latest action; the next action clears it.
function setStatus(text) { $('status').textContent = text; }

function changed(isMovement) {
  if (isMovement) {
    moving = true;
    clearTimeout(settleTimer);
    settleTimer = setTimeout(() => { moving = false; if (lastSentScale < 1) { dirty = true; pump(); } }, SETTLE_MS);
  }
  if (!lastError) setStatus('');
  showOutputs();
  dirty = true;
  pump();
}

// --- the frame stream ---
function connect() {
  socket = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => { setStatus(''); inFlight = false; dirty = true; pump(); };
  socket.onclose = () => {
    setStatus('disconnected from femto view; retrying');
    inFlight = false;
    setTimeout(connect, 1000);
  };
  socket.onmessage = (event) => {
    inFlight = false;
    if (typeof event.data === 'string') {
      const refusal = JSON.parse(event.data);
      lastError = refusal.error;
      setStatus(refusal.error);
      playing = false; $('play').textContent = 'Play';
    } else {
      const buf = event.data;
      bytesReceived += buf.byteLength;
      const n = new DataView(buf).getUint32(0, true);
      const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
      const blob = new Blob([new Uint8Array(buf, 4 + n)], { type: 'image/jpeg' });
      createImageBitmap(blob).then((bitmap) => { framesDecoded += 1; draw(header, bitmap); });
      if (lastError) { lastError = null; setStatus(''); }
      if (playing) advance();
    }
    pump();
  };
}

function pump() {
  if (!dirty || inFlight || !socket || socket.readyState !== WebSocket.OPEN) return;
  const s = (moving && !playing) ? REDUCED_SCALE : 1;
  seq += 1;
  socket.send(JSON.stringify(jpegQuality ? { seq, scale: s, quality: jpegQuality, state } : { seq, scale: s, state }));
  lastSentScale = s;
  inFlight = true;
  dirty = false;
}

function draw(header, bitmap) {
  if (header.seq <= shownSeq) { bitmap.close(); return; }  // a newer frame is on screen
  shownSeq = header.seq;
  framesShown += 1;
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
  explainBlack(header.hud);
}

function framesPerSecond() {
  const now = performance.now();
  while (fpsTimes.length && now - fpsTimes[0] > 1000) fpsTimes.shift();
  return fpsTimes.length;
}

function showHud() {
  const h = lastHud;
  if (!h) return;
  const fps = framesPerSecond();
  const rate = fps ? `${fps} frames/s` : 'idle';
  const proper = tau === null ? 'press Play' : `${tau.toFixed(1)} ps since Play`;
  $('hud').textContent =
    `beta ${h.beta.toFixed(3)}  gamma ${h.gamma.toFixed(3)}  D ${h.doppler_min.toFixed(3)}..${h.doppler_max.toFixed(3)}  ` +
    `t ${h.t_world_ps.toFixed(1)} ps (world)  tau ${proper}  ` +
    `${h.width}x${h.height}  ${rate}  ${h.render_ms.toFixed(0)} ms/frame`;
}

// Why a frame is black, when it is.
function explainBlack(h) {
  if (lastError || h.lit_fraction > 0) { if ($('status').dataset.black) { setStatus(''); delete $('status').dataset.black; } return; }
  let why = 'black frame: no light reaches the camera at this time; move the time slider into the shaded lit range';
  if (!state.effects.unwarp && state.view === 'transient') {
    why = 'black frame: with unwarp off each pixel shows the light emitted at the reception time itself ' +
      '(no flight time), after the light at the camera has gone; move the time slider earlier';
  }
  setStatus(why);
  $('status').dataset.black = '1';
}

// --- the light curve under the time slider ---
function drawLightCurve() {
  const c = $('light-curve');
  if (!info || !info.light_curve.t_ps.length) return;
  const g = c.getContext('2d');
  const [t0, t1] = info.time_range_ps;
  const x = (t) => (t - t0) / (t1 - t0) * c.width;
  const { t_ps, mean, lit_range_ps } = info.light_curve;
  const top = Math.max(...mean) || 1;
  g.clearRect(0, 0, c.width, c.height);
  g.fillStyle = 'rgba(240,200,80,0.18)';
  g.fillRect(x(lit_range_ps[0]), 0, x(lit_range_ps[1]) - x(lit_range_ps[0]), c.height);
  g.beginPath();
  g.moveTo(0, c.height);
  t_ps.forEach((t, k) => g.lineTo(x(t), c.height - 2 - (c.height - 4) * mean[k] / top));
  g.lineTo(c.width, c.height);
  g.fillStyle = 'rgba(140,196,255,0.45)';
  g.fill();
  g.strokeStyle = '#f0c850';
  g.lineWidth = 2;
  const xt = x(state.t_world_ps);
  g.beginPath(); g.moveTo(xt, 0); g.lineTo(xt, c.height); g.stroke();
}

// --- the legends: received wavelengths, or the isochrones' times ---
// The legend draws the grey of invisible light at half brightness, so that it reads as grey.
function spectrumColour(nm) {
  const [v0, v1] = info.visible_nm;
  if (nm < v0 || nm > v1) return '#7a7a7a';
  const s = info.spectrum;
  const k = Math.max(0, Math.min(s.length - 1, Math.round((nm - s[0].nm) / (s[1].nm - s[0].nm))));
  return `rgb(${s[k].srgb8.join(',')})`;
}

function showLegend(h) {
  const iso = h.isochrones;
  $('spectrum-legend').hidden = !!iso;
  $('iso-legend').hidden = !iso;
  if (iso) { showIsoLegend(iso); return; }
  const c = $('spectrum');
  const g = c.getContext('2d');
  const s = info.spectrum;
  const [a, b] = [s[0].nm, s[s.length - 1].nm];
  const x = (nm) => Math.max(0, Math.min(c.width, (nm - a) / (b - a) * c.width));
  for (const e of s) { g.fillStyle = spectrumColour(e.nm); g.fillRect(x(e.nm - 2.5), 0, x(e.nm + 2.5) - x(e.nm - 2.5) + 1, 12); }
  g.clearRect(0, 12, c.width, c.height - 12);
  const doppler = state.effects.doppler;
  const visible = (nm) => Math.min(info.visible_nm[1], Math.max(info.visible_nm[0], nm));
  const [lo, hi] = doppler ? [h.doppler_min * h.laser_nm, h.doppler_max * h.laser_nm] : [visible(h.laser_nm), visible(h.laser_nm)];
  g.fillStyle = '#ffffff';
  g.fillRect(x(lo), 13, Math.max(2, x(hi) - x(lo)), 8);
  g.font = '10px sans-serif'; g.fillStyle = '#000';
  g.fillText('UV: grey', 4, 10);
  g.fillText('IR: grey', c.width - 48, 10);
  g.fillRect(x(h.laser_nm) - 1, 0, 3, 12);
  g.fillStyle = '#fff'; g.fillRect(x(h.laser_nm), 0, 1, 12);
  const [v0, v1] = info.visible_nm;
  const band = (nm) => nm < v0 ? 'UV' : nm > v1 ? 'IR' : 'visible';
  const outside = doppler && [lo, hi].some((nm) => nm < v0 || nm > v1);
  // color::nearest_visible_nm: without Doppler an invisible laser is drawn at the nearer end
  // of the visible range.
  const drawn = visible(h.laser_nm);
  const range = doppler
    ? `received ${lo.toFixed(0)}-${hi.toFixed(0)} nm (${band(lo)}${band(hi) !== band(lo) ? ' to ' + band(hi) : ''})`
    : `doppler off: every pixel in the laser's colour` +
      (drawn !== h.laser_nm ? ` (${band(h.laser_nm)}: drawn at ${drawn} nm, the nearest visible colour)` : '');
  $('legend-text').textContent =
    `laser ${h.laser_nm.toFixed(0)} nm (black tick); ${range} (white bar). ` +
    `Light outside ${v0}-${v1} nm (UV or IR) is drawn grey` +
    (outside ? ': part of this frame is grey because its light is shifted out of the visible range.' : '.');
  $('legend-text').dataset.range = `${lo.toFixed(1)}-${hi.toFixed(1)}`;
}

function showIsoLegend(iso) {
  const c = $('iso-bar');
  const g = c.getContext('2d');
  // views::hue_ramp: blue, cyan, green, yellow, red.
  const grad = g.createLinearGradient(0, 0, c.width, 0);
  ['#0000ff', '#00ffff', '#00ff00', '#ffff00', '#ff0000'].forEach((col, k) => grad.addColorStop(k / 4, col));
  g.fillStyle = grad;
  g.fillRect(0, 0, c.width, c.height);
  g.fillStyle = 'rgba(0,0,0,0.85)';
  const span = iso.t_max_ps - iso.t_min_ps;
  for (let t = Math.ceil(iso.t_min_ps / iso.contour_ps) * iso.contour_ps; t <= iso.t_max_ps; t += iso.contour_ps) {
    g.fillRect((t - iso.t_min_ps) / span * c.width - 1, 0, 2, c.height);
  }
  $('iso-text').textContent =
    `arrival of the laser's direct light at the camera: ${iso.t_min_ps.toFixed(0)} ps (blue) to ` +
    `${iso.t_max_ps.toFixed(0)} ps (red), contours every ${round(iso.contour_ps, 3)} ps; ` +
    'mid-grey: the laser does not see the point (no direct pulse); black: no surface. From the mesh, not the cube.';
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

// One frame interval of proper time along the camera's straight, uniform motion, or the
// next frame of a loaded path. Straight play loops over the light curve's lit range.
function advance() {
  if (loadedFrames) {
    loadedIndex += 1;
    if (loadedIndex >= loadedFrames.length) { playing = false; $('play').textContent = 'Play'; return; }
    state = JSON.parse(JSON.stringify(loadedFrames[loadedIndex]));
    tau += state.dtau_ps;
  } else {
    const g = state.effects.dilation ? gamma(state.beta) : 1;
    state.t_world_ps += g * state.dtau_ps;
    state.position_m = add(state.position_m, scale(state.beta, C_M_PER_PS * g * state.dtau_ps));
    tau += state.dtau_ps;
    const [a, b] = info.light_curve.lit_range_ps;
    if (state.t_world_ps > b) state.t_world_ps = a;
    $('time').value = state.t_world_ps;
  }
  showOutputs();
  dirty = true;
}

// --- input ---
// Keys fly the camera wherever focus is, except in a text field; a slider takes keys only
// when it was reached with Tab.
let tabbedTo = null;
function flies(target) {
  if (!target || target === document.body) return true;
  if (target.tagName === 'TEXTAREA') return false;
  if (target.tagName === 'INPUT') {
    if (target.type === 'range') return target !== tabbedTo;
    return target.type === 'checkbox' || target.type === 'button';
  }
  return true;
}

function key(e) {
  if (e.ctrlKey || e.metaKey || e.altKey || !state) return;
  if (!flies(e.target)) return;
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
  changed(true);
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
    state = JSON.parse(JSON.stringify(info.capture_state));
    worldDirection = null; tau = null; loadedFrames = null;
    syncControls(); changed(false);
  };
  $('vfov').oninput = () => { state.vfov_deg = +$('vfov').value; changed(true); };
  $('size').onchange = () => {
    const [w, h] = $('size').value.split('x').map(Number);
    state.width = w; state.height = h; changed(false);
  };
  $('beta').oninput = () => { updateBeta(); changed(true); };
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
  $('time').oninput = () => { state.t_world_ps = +$('time').value; changed(true); };
  $('dtau').onchange = () => {
    const d = +$('dtau').value;
    if (d > 0) { state.dtau_ps = d; $('time').step = 'any'; changed(false); }
  };
  $('play').onclick = () => {
    playing = !playing;
    $('play').textContent = playing ? 'Pause' : 'Play';
    if (playing && loadedFrames && loadedIndex >= loadedFrames.length - 1) loadedIndex = -1;
    if (playing) {
      tau = 0;
      const [a, b] = info.light_curve.lit_range_ps;
      if (!loadedFrames && (state.t_world_ps < a || state.t_world_ps > b)) state.t_world_ps = a - gamma(state.beta) * state.dtau_ps;
      advance(); changed(false);
    }
  };
  for (const box of document.querySelectorAll('[data-effect]')) {
    box.onchange = () => {
      state.effects[box.dataset.effect] = box.checked;
      $('effect-note').textContent = EFFECT_NOTES[box.dataset.effect];
      changed(false);
    };
  }
  $('view-kind').onchange = () => { state.view = $('view-kind').value; changed(false); };
  $('radiometry').onchange = () => { state.radiometry = $('radiometry').value; changed(false); };
  $('exposure').oninput = () => { state.exposure = Math.pow(2, +$('exposure').value); changed(true); };
  $('laser').onchange = () => { const l = +$('laser').value; if (l > 0) { state.laser_nm = l; changed(false); } };
  $('add-keyframe').onclick = () => {
    keyframes.push(JSON.parse(JSON.stringify(state)));
    saveKeyframes(); showKeyframes();
  };
  $('clear-keyframes').onclick = () => { keyframes = []; saveKeyframes(); showKeyframes(); };
  $('export-path').onclick = exportPath;
  $('load-path').onchange = async () => {
    const file = $('load-path').files[0];
    if (!file) return;
    try {
      const loaded = await api('POST', '/api/path', await file.text(), 'application/toml');
      loadedFrames = loaded.frames; loadedIndex = 0;
      state = JSON.parse(JSON.stringify(loadedFrames[0])); tau = null;
      syncControls(); changed(false);
      setStatus(`loaded ${loadedFrames.length} frames: press Play`);
    } catch (e) { setStatus(e.message); }
  };

  // Mouse look.
  let drag = null;
  canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); canvas.focus(); });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const k = (state.vfov_deg * Math.PI / 180) / canvas.clientHeight;
    const [dx, dy] = [e.clientX - drag[0], e.clientY - drag[1]];
    drag = [e.clientX, e.clientY];
    turn(info.up, -dx * k);
    turn(right(), -dy * k);
    loadedFrames = null;
    updateBeta(); changed(true);
  });
  // The frame rate says "idle" when nothing has been drawn for a second.
  setInterval(showHud, 500);
}

// The server refuses a POST that does not say what it sends (docs/view.md, "Access").
async function api(method, url, body, contentType = 'application/json') {
  const headers = body === undefined ? {} : { 'Content-Type': contentType };
  const r = await fetch(url, { method, body, headers, credentials: 'same-origin' });
  if (!r.ok) { const text = (await r.text()).trim(); setStatus(text); throw new Error(text); }
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
    go.onclick = () => { state = JSON.parse(JSON.stringify(k)); loadedFrames = null; syncControls(); changed(false); };
    const del = document.createElement('button');
    del.textContent = 'Delete';
    del.onclick = () => { keyframes.splice(i, 1); saveKeyframes(); showKeyframes(); };
    li.append(go, del);
    ol.append(li);
  });
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
  state = JSON.parse(JSON.stringify(info.capture_state));
  const [t0, t1] = info.time_range_ps;
  Object.assign($('time'), { min: t0, max: t1, step: 'any' });
  syncControls();
  bind();
  loadKeyframes();
  showKeyframes();
  connect();
}

// For scripts and the browser test: the page's state and what it has shown.
window.femto = {
  get state() { return state; },
  get info() { return info; },
  get shownSeq() { return shownSeq; },
  get framesShown() { return framesShown; },
  get framesDecoded() { return framesDecoded; },
  get bytesReceived() { return bytesReceived; },
  get keyframes() { return keyframes; },
  get hud() { return lastHud; },
  get error() { return lastError; },
  // JPEG quality of the frames asked for, 1-100 (null: the server's default).
  get quality() { return jpegQuality; },
  set quality(q) { jpegQuality = q; },
  // The frame of the current state is on screen at full size, and nothing is pending.
  get settled() {
    return !dirty && !inFlight && !moving && !playing && lastSentScale === 1 && shownSeq === seq;
  },
};

start();
