// femto view: the page. It keeps one camera state (the JSON of docs/view.md), sends it on
// the WebSocket /ws whenever it changes and the frame before has arrived, and draws the
// frames that come back; a frame older than the one on screen is never drawn.
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
let tau = 0;                // the camera's proper time elapsed, ps (HUD)
let socket = null;
let seq = 0, shownSeq = 0, framesShown = 0;
let inFlight = false, dirty = false, moving = false, settleTimer = null;
let lastSentScale = 1;
let playing = false, loadedFrames = null, loadedIndex = 0;
let lastHud = null, lastError = null, fpsTimes = [];

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

function syncControls() {
  $('vfov').value = state.vfov_deg;
  $('size').value = `${state.width}x${state.height}`;
  if (![...$('size').options].some((o) => o.value === $('size').value)) {
    const o = new Option(`${state.width} x ${state.height}`, `${state.width}x${state.height}`);
    $('size').add(o); $('size').value = o.value;
  }
  $('beta').value = Math.min(norm(state.beta), 0.999);
  $('time').value = state.t_world_ps;
  $('dtau').value = state.dtau_ps;
  $('spin-axis').value = state.rotation ? state.rotation.axis : '';
  if (state.rotation) $('spin-beta').value = state.rotation.beta_edge;
  for (const box of document.querySelectorAll('[data-effect]')) box.checked = state.effects[box.dataset.effect];
  $('view-kind').value = state.view;
  $('radiometry').value = state.radiometry;
  $('exposure').value = Math.log2(state.exposure);
  $('laser').value = state.laser_nm;
  showOutputs();
}

function showOutputs() {
  $('vfov-out').textContent = `${(+$('vfov').value).toFixed(1)} deg`;
  $('beta-out').textContent = (+$('beta').value).toFixed(3);
  $('spin-beta-out').textContent = (+$('spin-beta').value).toFixed(2);
  $('time-out').textContent = (+state.t_world_ps).toFixed(1);
  $('exposure-out').textContent = `${(+$('exposure').value).toFixed(2)}`;
}

function changed(isMovement) {
  if (isMovement) {
    moving = true;
    clearTimeout(settleTimer);
    settleTimer = setTimeout(() => { moving = false; if (lastSentScale < 1) { dirty = true; pump(); } }, SETTLE_MS);
  }
  showOutputs();
  dirty = true;
  pump();
}

// --- the frame stream ---
function connect() {
  socket = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => { $('status').textContent = ''; inFlight = false; dirty = true; pump(); };
  socket.onclose = () => {
    $('status').textContent = 'disconnected from femto view; retrying';
    inFlight = false;
    setTimeout(connect, 1000);
  };
  socket.onmessage = (event) => {
    inFlight = false;
    if (typeof event.data === 'string') {
      const refusal = JSON.parse(event.data);
      lastError = refusal.error;
      $('status').textContent = refusal.error;
      playing = false; $('play').textContent = 'Play';
    } else {
      const buf = event.data;
      const n = new DataView(buf).getUint32(0, true);
      const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
      const blob = new Blob([new Uint8Array(buf, 4 + n)], { type: 'image/jpeg' });
      createImageBitmap(blob).then((bitmap) => draw(header, bitmap));
      if (lastError) { lastError = null; $('status').textContent = ''; }
      if (playing) advance();
    }
    pump();
  };
}

function pump() {
  if (!dirty || inFlight || !socket || socket.readyState !== WebSocket.OPEN) return;
  const s = (moving && !playing) ? REDUCED_SCALE : 1;
  seq += 1;
  socket.send(JSON.stringify({ seq, scale: s, state }));
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
  const now = performance.now();
  fpsTimes.push(now);
  while (fpsTimes.length && now - fpsTimes[0] > 1000) fpsTimes.shift();
  const h = header.hud;
  $('hud').textContent =
    `beta  ${h.beta.toFixed(3)}   gamma ${h.gamma.toFixed(3)}\n` +
    `D     ${h.doppler_min.toFixed(3)} .. ${h.doppler_max.toFixed(3)}\n` +
    `t     ${h.t_world_ps.toFixed(1)} ps (world)\n` +
    `tau   ${tau.toFixed(1)} ps (proper, elapsed)\n` +
    `${h.width} x ${h.height}   ${fpsTimes.length} frames/s   ${h.render_ms.toFixed(1)} ms`;
}

// One frame interval of proper time along the camera's straight, uniform motion, or the
// next frame of a loaded path.
function advance() {
  if (loadedFrames) {
    loadedIndex += 1;
    if (loadedIndex >= loadedFrames.length) { playing = false; $('play').textContent = 'Play'; return; }
    state = JSON.parse(JSON.stringify(loadedFrames[loadedIndex]));
    tau += state.dtau_ps;
  } else {
    const g = gamma(state.beta);
    state.t_world_ps += g * state.dtau_ps;
    state.position_m = add(state.position_m, scale(state.beta, C_M_PER_PS * g * state.dtau_ps));
    tau += state.dtau_ps;
    if (state.t_world_ps > info.time_range_ps[1]) state.t_world_ps = info.time_range_ps[0];
    $('time').value = state.t_world_ps;
  }
  showOutputs();
  dirty = true;
}

// --- input ---
function bind() {
  $('reset').onclick = () => {
    state = JSON.parse(JSON.stringify(info.capture_state));
    worldDirection = null; tau = 0; loadedFrames = null;
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
  $('time').oninput = () => {
    const t = +$('time').value;
    tau += (t - state.t_world_ps) / gamma(state.beta);
    state.t_world_ps = t; changed(true);
  };
  $('dtau').onchange = () => {
    const d = +$('dtau').value;
    if (d > 0) { state.dtau_ps = d; $('time').step = d; changed(false); }
  };
  $('play').onclick = () => {
    playing = !playing;
    $('play').textContent = playing ? 'Pause' : 'Play';
    if (playing && loadedFrames && loadedIndex >= loadedFrames.length - 1) loadedIndex = -1;
    if (playing) { advance(); changed(false); }
  };
  for (const box of document.querySelectorAll('[data-effect]')) {
    box.onchange = () => { state.effects[box.dataset.effect] = box.checked; changed(false); };
  }
  $('view-kind').onchange = () => { state.view = $('view-kind').value; changed(false); };
  $('radiometry').onchange = () => { state.radiometry = $('radiometry').value; changed(false); };
  $('exposure').oninput = () => { state.exposure = Math.pow(2, +$('exposure').value); changed(true); };
  $('laser').onchange = () => { const l = +$('laser').value; if (l > 0) { state.laser_nm = l; changed(false); } };
  $('add-keyframe').onclick = () => api('POST', '/api/keyframes', JSON.stringify(state)).then(showKeyframes);
  $('export-path').onclick = exportPath;
  $('load-path').onchange = async () => {
    const file = $('load-path').files[0];
    if (!file) return;
    try {
      const loaded = await api('POST', '/api/path', await file.text(), 'application/toml');
      loadedFrames = loaded.frames; loadedIndex = 0;
      state = JSON.parse(JSON.stringify(loadedFrames[0])); tau = 0;
      syncControls(); changed(false);
      $('status').textContent = `loaded ${loadedFrames.length} frames: press Play`;
    } catch (e) { $('status').textContent = e.message; }
  };

  // Mouse look and keys.
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
  canvas.addEventListener('keydown', (e) => {
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
  });
}

// The server refuses a POST that does not say what it sends (docs/view.md, "Access").
async function api(method, url, body, contentType = 'application/json') {
  const headers = body === undefined ? {} : { 'Content-Type': contentType };
  const r = await fetch(url, { method, body, headers, credentials: 'same-origin' });
  if (!r.ok) { const text = (await r.text()).trim(); $('status').textContent = text; throw new Error(text); }
  const type = r.headers.get('Content-Type') || '';
  return type.startsWith('application/json') ? r.json() : r.text();
}

function showKeyframes(list) {
  const ol = $('keyframes');
  ol.textContent = '';
  list.forEach((k, i) => {
    const li = document.createElement('li');
    li.textContent = `t ${k.t_world_ps.toFixed(1)} ps, beta ${norm(k.beta).toFixed(3)}`;
    const go = document.createElement('button');
    go.textContent = 'Go to';
    go.onclick = () => { state = JSON.parse(JSON.stringify(k)); loadedFrames = null; syncControls(); changed(false); };
    const del = document.createElement('button');
    del.textContent = 'Delete';
    del.onclick = () => api('DELETE', `/api/keyframes/${i}`).then(showKeyframes);
    li.append(go, del);
    ol.append(li);
  });
}

async function exportPath() {
  try {
    const text = await api('GET', '/api/path.toml');
    $('path-toml').value = text;
    const link = $('path-download');
    link.href = URL.createObjectURL(new Blob([text], { type: 'application/toml' }));
    link.hidden = false;
  } catch (e) { /* shown in the status line */ }
}

async function start() {
  info = await api('GET', '/api/info');
  state = JSON.parse(JSON.stringify(info.capture_state));
  const [t0, t1] = info.time_range_ps;
  Object.assign($('time'), { min: t0, max: t1, step: state.dtau_ps });
  syncControls();
  bind();
  showKeyframes(await api('GET', '/api/keyframes'));
  connect();
}

// For scripts and the browser test: the page's state and what it has shown.
window.femto = {
  get state() { return state; },
  get shownSeq() { return shownSeq; },
  get framesShown() { return framesShown; },
  get hud() { return lastHud; },
  get error() { return lastError; },
  // The frame of the current state is on screen at full size, and nothing is pending.
  get settled() {
    return !dirty && !inFlight && !moving && !playing && lastSentScale === 1 && shownSeq === seq;
  },
};

start();
