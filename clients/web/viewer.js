// viewer.js - the meshsteer browser viewer: connects to the daemon's /stream (docs/PROTOCOL.md),
// shows the synthesised mesh (lit, smooth normals, soft shadows on a ground grid, orbit camera), the
// incoming markers as dots, optional colouring by model part, and an overlay with fps, end-to-end
// latency (and a sparkline of both), dropped frames, how many markers are bound (its tooltip: which
// live label drives each), the model kind and what drives it. Playback controls (pause/resume, seek,
// speed) appear for the controls the hello's source.controls offers; a screenshot button saves a PNG
// and a record button a WebM clip (MediaRecorder). It reconnects by itself (the camera is kept) and
// exposes its counters as window.meshsteer for tests. With ?nats=ws://HOST:PORT[,...] it reads the
// same messages from a NATS server's WebSocket listener instead (nats_link.js). With the params
// encoding (?encoding=params, docs/PROTOCOL.md 2b) params.js rebuilds positions and normals on the GPU.
import * as THREE from './node_modules/three/build/three.module.js';
import { Orbit } from './orbit.js';
import * as P from './protocol.js';
import * as PP from './params.js';

const params = new URLSearchParams(location.search);
const stats = {
  connected: false, connects: 0, reconnects: 0, hellos: 0, topologies: 0,
  frames: 0,          // frame messages received
  colouring: 'parts', // what "colour by part" shows: 'parts', or a skin's 'bone weights'
  rendered: 0,        // frames drawn
  dropped: 0,         // skipped by the server (slow link) + replaced before they were drawn
  errors: 0, lastError: '',
  latencyMs: NaN,     // capture -> on screen, smoothed; NaN until the clock offset is known
  fps: 0, generation: 0,
  tickHz: 0,          // animation frames the browser gave the page per second (what it can draw)
  ticks: 0,           // animation frames the browser gave the page, in all
  readyTicks: 0,      // of those, the ones that began with a received frame not yet drawn
  readyDrawn: 0,      // of those, the ones on which the page drew a new frame (it should: all)
  encoding: ['int16', 'params'].includes(params.get('encoding')) ? params.get('encoding') : 'float32',
  paramsModels: 0, paramsFrames: 0, // params models (MSPM) and params frames received
  transport: '',      // 'websocket' (the daemon's /stream) or 'nats' (?nats=ws://...)
  coalesced: 0,       // NATS: frames that arrived but a newer one replaced before decoding
  nv: 0, nf: 0, nm: 0, lastSeq: 0, lastCaptureUs: 0, model: '',
  bound: 0,           // model markers bound to a live label (hello markers[].bound)
  controls: [],       // the source controls the hello offers (source.controls)
  kind: '',           // model kind (hello model.kind; protocol-1 servers without it run 'steer')
  driver: '',         // 'tracked', or 'reference lost' / 'held' from the frame flags
  sourceFrames: 0,    // frames of the source (hello source.frames; 0 for a live one)
  paused: false, speed: 1, position: NaN, // the playback state as the viewer last set it
  acks: 0,            // control requests acknowledged
  framesSinceAck: 0,  // frames received after the last ack that were made after its control
  ackSeq: 0,          // the last ack's seq: the newest frame made before its control
  screenshots: 0, lastShotBytes: 0, clips: 0, lastClipBytes: 0, lastClipType: '',
  history: [],        // [fps, latency ms] every 0.5 s, the last 60 (the sparkline)
  shadows: false, grid: false, smoothGroups: 0,
};
window.meshsteer = stats;
// the newest decoded markers (model marker order) and their live labels, for tests
window.meshsteerMarkers = () => ({ xyz: Array.from(decoded.markers || []), valid: Array.from(decoded.valid || []),
                                   live: stats.live });
// the newest decoded vertex positions (nv x 3), for tests
window.meshsteerVertices = () => Array.from(decoded.V || []);

const el = id => document.getElementById(id);

// ---- three.js scene
const view = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.shadowMap.enabled = true;
renderer.shadowMap.type = THREE.PCFSoftShadowMap;
// Shadows cost a second pass over the mesh: in software WebGL (SwiftShader, headless browsers and
// machines without a GPU) the map is smaller and is redrawn every second frame, out of sight.
const gl = renderer.getContext(), dbg = gl.getExtension('WEBGL_debug_renderer_info');
const software = /swiftshader|llvmpipe|software/i.test(dbg ? gl.getParameter(dbg.UNMASKED_RENDERER_WEBGL) : '');
renderer.shadowMap.autoUpdate = false;
let shadowTick = 0;
stats.shadows = true;
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242a);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404650, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(3, 5, 4);
sun.castShadow = true;
sun.shadow.mapSize.set(software ? 512 : 2048, software ? 512 : 2048);
sun.shadow.radius = 4;
sun.shadow.bias = -0.0005;
scene.add(sun, sun.target);
// the ground: a grid and a plane that only receives the shadow, both placed under the rest pose
const ground = new THREE.Group();
const shadowPlane = new THREE.Mesh(new THREE.PlaneGeometry(1, 1),
                                   new THREE.ShadowMaterial({ color: 0x000000, opacity: 0.35 }));
shadowPlane.rotation.x = -Math.PI / 2;
shadowPlane.receiveShadow = true;
ground.add(shadowPlane);
scene.add(ground);
let grid = null;
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
let dirty = true;
const orbit = new Orbit(camera, renderer.domElement, () => { dirty = true; });
orbit.update();

let mesh = null, points = null, topo = null;
let baseMaterial = null, paramsModel = null, paramsMesh = null; // params.js: the GPU rebuild
// tests: the positions the params shader gives for a recent params frame (transform feedback):
// the parameters of the last 120 params frames are kept by sequence number
const recentParams = new Map();
window.meshsteerParams = {
  seqs: kind => Array.from(recentParams.keys())
    .filter(q => paramsModel && paramsModel.layouts[recentParams.get(q).layout].kind === kind),
  snapshot: seq => {
    const r = paramsModel && recentParams.get(seq);
    return r ? { seq, layout: r.layout, kind: paramsModel.layouts[r.layout].kind,
                 V: Array.from(PP.readback(paramsModel, r.layout, r.prm)) } : null;
  },
  material: () => Boolean(mesh && paramsMesh && mesh.material === paramsMesh.material),
  positions: () => paramsMesh ? Array.from(paramsMesh.positions(renderer)) : null, // what is drawn
  colours: () => mesh ? Array.from(mesh.geometry.attributes.color.array) : null, // per vertex, drawn
  // a skin layout's weights: per vertex, [bone, weight] of its slots in use
  skinWeights: () => {
    const L = paramsModel && paramsModel.layouts.find(L => L.kind === PP.KIND_SKIN);
    if (!L) return null;
    const out = [];
    for (let v = 0; v < paramsModel.nv; v++) {
      const row = [];
      for (let s = 0; s < L.slots; s++) {
        const t = 4 * (v * L.slots + s);
        if (L.slotTex[t + 2] !== 0) row.push([L.slotTex[t + 1], L.slotTex[t + 2]]);
      }
      out.push(row);
    }
    return out;
  },
  drawnSeq: 0, // the params frame those positions are of
};
const decoded = { V: null, markers: null, valid: null };
let pending = null; // newest decoded frame header not yet drawn

const partsBox = document.getElementById('c-parts');
const markersBox = document.getElementById('c-markers');
const int16Box = document.getElementById('c-int16');
const paramsBox = document.getElementById('c-params');
const groundBox = document.getElementById('c-ground');
int16Box.checked = stats.encoding === 'int16';
paramsBox.checked = stats.encoding === 'params';

// "colour by part": the topology's part of each vertex (a skin's: its strongest bone); while a
// skin's params frames are drawn, the skin's weights as colour instead (params.js,
// boneWeightColours: the params model is what carries the weights)
const colours = { parts: null, bones: null, shown: 'parts' };
function showColours(which) {
  if (which === 'bone weights' && !colours.bones) which = 'parts';
  if (colours.shown === which || !mesh) return;
  const c = mesh.geometry.attributes.color;
  c.array.set(which === 'parts' ? colours.parts : colours.bones);
  c.needsUpdate = true;
  colours.shown = stats.colouring = which;
}

function partColours(parts, nparts) {
  const c = new Float32Array(parts.length * 3), col = new THREE.Color();
  for (let i = 0; i < parts.length; i++) {
    col.setHSL((parts[i] * 0.618034) % 1, 0.55, 0.55);
    c[3 * i] = col.r; c[3 * i + 1] = col.g; c[3 * i + 2] = col.b;
  }
  return c;
}

function buildMesh(t) {
  if (mesh) { scene.remove(mesh); mesh.geometry.dispose(); }
  if (points) { scene.remove(points); points.geometry.dispose(); }
  const g = new THREE.BufferGeometry();
  const pos = new THREE.BufferAttribute(new Float32Array(t.rest), 3);
  pos.setUsage(THREE.DynamicDrawUsage);
  g.setAttribute('position', pos);
  colours.parts = partColours(t.parts, t.nparts);
  colours.bones = null;
  colours.shown = 'parts';
  stats.colouring = 'parts';
  g.setAttribute('color', new THREE.BufferAttribute(colours.parts.slice(), 3));
  g.setIndex(new THREE.BufferAttribute(t.faces, 1));
  g.computeVertexNormals();
  g.computeBoundingSphere();
  const mat = new THREE.MeshStandardMaterial({ color: 0xc9b79c, roughness: 0.6, metalness: 0.0,
                                               vertexColors: partsBox.checked, side: THREE.DoubleSide });
  baseMaterial = mat;
  mesh = new THREE.Mesh(g, mat);
  mesh.frustumCulled = false;
  mesh.castShadow = true;
  scene.add(mesh);
  const pg = new THREE.BufferGeometry();
  const mpos = new THREE.BufferAttribute(new Float32Array(Math.max(1, t.nm) * 3), 3);
  mpos.setUsage(THREE.DynamicDrawUsage);
  pg.setAttribute('position', mpos);
  pg.setDrawRange(0, 0);
  points = new THREE.Points(pg, new THREE.PointsMaterial({ color: 0xff3d3d, size: 8, sizeAttenuation: false,
                                                           depthTest: false }));
  points.frustumCulled = false;
  points.renderOrder = 1;
  points.visible = markersBox.checked;
  scene.add(points);
  decoded.V = new Float32Array(t.nv * 3);
  decoded.markers = new Float32Array(t.nm * 3);
  decoded.valid = new Uint8Array(t.nm);
  // frame the rest pose once; reconnects and reloads keep the user's camera
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < t.nv * 3; i++) {
    const a = i % 3;
    min[a] = Math.min(min[a], t.rest[i]); max[a] = Math.max(max[a], t.rest[i]);
  }
  orbit.frame(min, max);
  placeGround(min, max);
  smoothGroups(t);
  dirty = true;
}

// a grid of 10 lines per model size under the rest pose, and the sun's shadow camera around it
function placeGround(min, max) {
  const size = Math.max(max[0] - min[0], max[2] - min[2], max[1] - min[1], 1e-3);
  const cx = (min[0] + max[0]) / 2, cz = (min[2] + max[2]) / 2, extent = size * 4;
  if (grid) { ground.remove(grid); grid.geometry.dispose(); grid.material.dispose(); }
  const step = Math.pow(10, Math.floor(Math.log10(size / 2)));
  const divisions = Math.min(400, Math.round(extent / step));
  grid = new THREE.GridHelper(divisions * step, divisions, 0x6a7380, 0x3a4048);
  grid.position.set(cx, 0, cz);
  ground.add(grid);
  stats.grid = true;
  shadowPlane.scale.set(extent, extent, 1);
  shadowPlane.position.set(cx, 0.001 * size, cz);
  ground.position.y = min[1];
  const cam = sun.shadow.camera, r = size * 1.5;
  cam.left = -r; cam.right = r; cam.top = r; cam.bottom = -r;
  cam.near = 0.01; cam.far = size * 20;
  cam.updateProjectionMatrix();
  sun.target.position.set(cx, (min[1] + max[1]) / 2, cz);
  sun.position.set(cx + size * 0.6, max[1] + size * 3, cz + size * 1.2); // high: the shadow lies under it
  ground.visible = groundBox.checked;
}

// Smooth normals: computeVertexNormals averages the faces around each vertex, but a mesh whose
// vertices are split at seams (OBJ with per-face normals or UVs) would still show its seams; the
// copies of one rest position share one normal (groups found once per topology).
let dupFrom = null, dupTo = null;
function smoothGroups(t) {
  const first = new Map(), from = [], to = [];
  for (let i = 0; i < t.nv; i++) {
    const key = `${t.rest[3 * i]},${t.rest[3 * i + 1]},${t.rest[3 * i + 2]}`;
    const j = first.get(key);
    if (j === undefined) first.set(key, i); else { from.push(i); to.push(j); }
  }
  dupFrom = from.length ? Int32Array.from(from) : null;
  dupTo = from.length ? Int32Array.from(to) : null;
  stats.smoothGroups = from.length;
}
function normals(g) {
  g.computeVertexNormals();
  if (!dupFrom) return;
  const n = g.attributes.normal.array;
  for (let k = 0; k < dupFrom.length; k++) { // accumulate the copies into the first ...
    const a = 3 * dupFrom[k], b = 3 * dupTo[k];
    n[b] += n[a]; n[b + 1] += n[a + 1]; n[b + 2] += n[a + 2];
  }
  for (let k = 0; k < dupFrom.length; k++) { // ... normalise it and copy it back
    const a = 3 * dupFrom[k], b = 3 * dupTo[k];
    const l = Math.hypot(n[b], n[b + 1], n[b + 2]) || 1;
    n[a] = n[b] / l; n[a + 1] = n[b + 1] / l; n[a + 2] = n[b + 2] / l;
  }
  for (let k = 0; k < dupFrom.length; k++) {
    const b = 3 * dupTo[k];
    const l = Math.hypot(n[b], n[b + 1], n[b + 2]) || 1;
    n[b] /= l; n[b + 1] /= l; n[b + 2] /= l;
  }
  g.attributes.normal.needsUpdate = true;
}

partsBox.addEventListener('change', () => {
  const mats = [baseMaterial, paramsMesh && paramsMesh.material];
  for (const m of mats) if (m) { m.vertexColors = partsBox.checked; m.needsUpdate = true; }
  dirty = true;
});
groundBox.addEventListener('change', () => { ground.visible = groundBox.checked; dirty = true; });
markersBox.addEventListener('change', () => { if (points) { points.visible = markersBox.checked; dirty = true; } });
function chooseEncoding(box) {
  if (box.checked) (box === int16Box ? paramsBox : int16Box).checked = false;
  stats.encoding = paramsBox.checked ? 'params' : int16Box.checked ? 'int16' : 'float32';
  send({ type: 'encoding', encoding: stats.encoding });
}
int16Box.addEventListener('change', () => chooseEncoding(int16Box));
paramsBox.addEventListener('change', () => chooseEncoding(paramsBox));

// ---- clock: map performance.now() (ms) to the server's CLOCK_MONOTONIC (us) with ping/pong,
// keeping the sample with the smallest round trip
let offsetMs = NaN, bestRtt = Infinity, pingSent = 0, pingOpen = false, pingBurst = 0;
function ping() {
  if (pingOpen && performance.now() - pingSent < 5000) return; // one ping in flight at a time
  pingSent = performance.now();
  pingOpen = true;
  send({ type: 'ping' });
}
function serverNowMs() { return performance.now() + offsetMs; }

// ---- the connection: the daemon's /stream, or (?nats=ws://...) a NATS server (nats_link.js)
let ws = null, link = null, backoff = 500, pingTimer = null;
const status = document.getElementById('status');
function setStatus(text, bad) { status.textContent = text; status.className = bad ? 'bad' : ''; }
function send(obj) {
  if (link) link.send(obj);
  else if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
}
function failed(e) {
  stats.errors++;
  stats.lastError = String(e);
  console.error(e);
}

function opened(label) {
  stats.connected = true;
  stats.connects++;
  if (stats.connects > 1) stats.reconnects++;
  backoff = 500;
  bestRtt = Infinity;
  setStatus(label);
  // The offset is only as good as the shortest round trip seen (its error is at most rtt/2), and
  // the first pings after a connect are slow (the page is still busy): eight pings one after the
  // other (each sent when the previous pong arrives, so a pong always answers the last ping), then
  // one every 2 s.
  pingOpen = false;
  pingBurst = 8;
  ping();
  clearInterval(pingTimer);
  pingTimer = setInterval(ping, 2000);
}
function closed(text) {
  stats.connected = false;
  clearInterval(pingTimer);
  setStatus(text, true);
}

function connect() {
  if (params.get('nats')) { connectNats(); return; }
  stats.transport = 'websocket';
  const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const token = params.get('token');
  const url = `${proto}//${location.host}/stream${token ? '?token=' + encodeURIComponent(token) : ''}`;
  ws = new WebSocket(url, 'meshsteer.v1');
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => {
    opened('connected');
    stats.ackSeq = 0; // a restarted daemon counts its frames from 1 again
    if (stats.encoding !== 'float32') send({ type: 'encoding', encoding: stats.encoding });
  };
  ws.onclose = () => {
    closed(`disconnected; retrying in ${(backoff / 1000).toFixed(1)} s`);
    setTimeout(connect, backoff);
    backoff = Math.min(backoff * 2, 5000);
  };
  ws.onmessage = ev => {
    try {
      if (typeof ev.data === 'string') onText(JSON.parse(ev.data));
      else onBinary(ev.data);
    } catch (e) {
      failed(e);
    }
  };
}

async function connectNats() {
  stats.transport = 'nats';
  const { natsLink } = await import('./nats_link.js');
  const guard = f => x => { try { f(x); } catch (e) { failed(e); } };
  link = natsLink(params.get('nats').split(','), params.get('subject') || 'meshsteer',
                  stats.encoding, {
    onOpen: () => opened('connected (NATS)'),
    onClose: closed,
    onText: guard(onText),
    onBinary: guard(onBinary),
    onSkipped: n => { stats.dropped += n; stats.coalesced += n; },
    onError: failed,
  });
}

function onText(msg) {
  if (msg.type === 'hello') {
    if (msg.protocol !== P.PROTOCOL) throw new Error(`server speaks protocol ${msg.protocol}`);
    stats.hellos++;
    stats.generation = msg.generation;
    stats.model = msg.model.name;
    stats.nm = msg.markers.length;
    stats.bound = msg.markers.filter(m => m.bound).length;
    stats.live = msg.markers.map(m => m.live ?? m.source);
    stats.controls = Array.isArray(msg.source && msg.source.controls) ? msg.source.controls : [];
    document.getElementById('title').textContent = `meshsteer – ${msg.model.name}`;
    stats.kind = msg.model.kind || 'steer';
    el('o-kind').textContent = `${msg.model.name} (${stats.kind})`;
    setupPlayback(msg.source || {});
    // which live marker drives each model marker (live: protocol 1 servers that know label maps)
    const mk = document.getElementById('o-markers');
    mk.textContent = `${stats.bound} of ${stats.nm} bound`;
    mk.title = msg.markers.map(m => `${m.name} ← ${m.live ?? m.source}${m.bound ? '' : ' (not in the source)'}`)
      .join('\n');
    topo = null; // the topology follows
  } else if (msg.type === 'pong') {
    const now = performance.now(), rtt = now - pingSent;
    pingOpen = false;
    if (rtt < bestRtt) { bestRtt = rtt; offsetMs = msg.server_us / 1000 - (pingSent + now) / 2; }
    if (pingBurst > 0 && --pingBurst > 0) ping();
  } else if (msg.type === 'ack') {
    stats.acks++;
    // a source control's ack names the newest frame made before the control took effect; those up
    // to it may still follow the ack (they were published, not yet written), the rest are the
    // control's
    stats.framesSinceAck = 0;
    stats.ackSeq = Number.isFinite(msg.seq) ? msg.seq : stats.lastSeq;
  } else if (msg.type === 'error') {
    stats.errors++;
    stats.lastError = `${msg.code}: ${msg.message}`;
  }
}

function onBinary(buf) {
  const k = P.kind(buf);
  if (k === 'topology') {
    topo = P.decodeTopology(buf);
    stats.topologies++;
    stats.nv = topo.nv; stats.nf = topo.nf;
    if (paramsMesh) paramsMesh.dispose();
    paramsMesh = paramsModel = null; // the new generation's params model follows, if asked for
    recentParams.clear();
    buildMesh(topo);
  } else if (PP.isParamsModel(buf) && topo) {
    paramsModel = PP.decodeParamsModel(buf);
    if (paramsModel.nv !== topo.nv) throw new Error('params model does not match the topology');
    if (paramsMesh) paramsMesh.dispose();
    const rep = Int32Array.from({ length: topo.nv }, (_, i) => i); // copies of one rest position
    if (dupFrom) for (let k = 0; k < dupFrom.length; k++) rep[dupFrom[k]] = dupTo[k];
    paramsMesh = new PP.ParamsMesh(THREE, paramsModel, baseMaterial, topo.faces, rep);
    recentParams.clear();
    const skin = paramsModel.layouts.findIndex(L => L.kind === PP.KIND_SKIN);
    colours.bones = skin >= 0 ? PP.boneWeightColours(paramsModel, skin) : null;
    showColours('parts');
    stats.paramsModels++;
  } else if (k === 'frame' && topo) {
    const h = P.decodeFrame(buf, topo, decoded);
    if (h.encoding === PP.ENC_PARAMS) {
      h.layout = PP.decodeParamsBlock(new DataView(buf), paramsModel);
      stats.paramsFrames++;
      recentParams.set(h.seq, { layout: h.layout, prm: paramsModel.layouts[h.layout].paramTex.slice() });
      if (recentParams.size > 120) recentParams.delete(recentParams.keys().next().value);
    }
    stats.frames++;
    stats.dropped += h.skipped;
    if (pending) stats.dropped++; // replaced before it was drawn
    stats.lastSeq = h.seq;
    stats.lastCaptureUs = h.tCapture;
    if (h.seq > stats.ackSeq) stats.framesSinceAck++;
    // flags bit 0: reference lost (the body pose is kept), bit 2: held (missing markers replaced),
    // bit 3: idle (no one is tracked; the model's idle animation made the frame)
    stats.driver = h.flags & 8 ? 'idle' : h.flags & 1 ? 'reference lost' : h.flags & 4 ? 'tracked (held)' : 'tracked';
    pending = h;
  }
}

// ---- drawing and the overlay
function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h, false);
  renderer.domElement.style.width = w + 'px';
  renderer.domElement.style.height = h + 'px';
  camera.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix();
  dirty = true;
}
window.addEventListener('resize', resize);
resize();

let fpsCount = 0, tickCount = 0, fpsT0 = performance.now();
function draw() {
  requestAnimationFrame(draw);
  tickCount++;
  stats.ticks++;
  // a received frame is waiting: decoded (pending), or still held by the NATS link
  const ready = pending !== null || (link !== null && link.waiting());
  if (ready) stats.readyTicks++;
  if (link) link.poll(); // the newest NATS frame that arrived since the last animation frame
  if (pending && mesh) {
    if (pending.encoding === PP.ENC_PARAMS) { // the GPU rebuilds the mesh
      paramsMesh.update(renderer, pending.layout);
      showColours(paramsModel.layouts[pending.layout].kind === PP.KIND_SKIN ? 'bone weights' : 'parts');
      mesh.material = paramsMesh.material;
      mesh.customDepthMaterial = paramsMesh.depth;
      window.meshsteerParams.drawnSeq = pending.seq;
    } else {
      mesh.material = baseMaterial;
      mesh.customDepthMaterial = undefined;
      showColours('parts');
      const pos = mesh.geometry.attributes.position;
      pos.array.set(decoded.V);
      pos.needsUpdate = true;
      normals(mesh.geometry);
    }
    const mp = points.geometry.attributes.position;
    let n = 0;
    for (let i = 0; i < topo.nm; i++)
      if (decoded.valid[i]) {
        mp.array[3 * n] = decoded.markers[3 * i];
        mp.array[3 * n + 1] = decoded.markers[3 * i + 1];
        mp.array[3 * n + 2] = decoded.markers[3 * i + 2];
        n++;
      }
    mp.needsUpdate = true;
    points.geometry.setDrawRange(0, n);
    if (!Number.isNaN(offsetMs)) {
      const lat = serverNowMs() - pending.tCapture / 1000;
      stats.latencyMs = Number.isNaN(stats.latencyMs) ? lat : 0.9 * stats.latencyMs + 0.1 * lat;
    }
    pending = null;
    stats.rendered++;
    if (ready) stats.readyDrawn++;
    fpsCount++;
    dirty = true;
  }
  if (dirty) {
    if (!software || (shadowTick++ & 1) === 0) renderer.shadowMap.needsUpdate = true;
    renderer.render(scene, camera);
    dirty = false;
  }
  const now = performance.now();
  if (now - fpsT0 >= 500) {
    stats.fps = fpsCount * 1000 / (now - fpsT0);
    stats.tickHz = tickCount * 1000 / (now - fpsT0);
    fpsCount = 0; tickCount = 0; fpsT0 = now;
    el('o-fps').textContent = stats.fps.toFixed(1);
    el('o-latency').textContent = Number.isNaN(stats.latencyMs) ? '–' : `${stats.latencyMs.toFixed(1)} ms`;
    el('o-dropped').textContent = String(stats.dropped);
    el('o-frames').textContent = String(stats.frames);
    el('o-encoding').textContent = stats.encoding;
    el('o-driver').textContent = stats.driver || '–';
    stats.history.push([stats.fps, stats.latencyMs]);
    if (stats.history.length > 60) stats.history.shift();
    sparkline();
    showPosition();
  }
}
// ---- the sparkline: fps (green, 0..max(60, seen)) and latency (orange, 0..max seen), 30 s
const spark = el('spark'), sg = spark.getContext('2d');
function sparkline() {
  const w = spark.width, h = spark.height, hs = stats.history;
  sg.clearRect(0, 0, w, h);
  const line = (k, top, colour) => {
    sg.strokeStyle = colour;
    sg.lineWidth = 1.5;
    sg.beginPath();
    let started = false;
    hs.forEach((v, i) => {
      if (!Number.isFinite(v[k])) return;
      const x = w - (hs.length - 1 - i) * (w / 59), y = h - 2 - (h - 4) * Math.min(1, v[k] / top);
      if (started) sg.lineTo(x, y); else { sg.moveTo(x, y); started = true; }
    });
    sg.stroke();
  };
  const maxOf = k => Math.max(...hs.map(v => (Number.isFinite(v[k]) ? v[k] : 0)));
  line(0, Math.max(60, maxOf(0)), '#7bd88f');
  line(1, Math.max(10, maxOf(1) * 1.1), '#ffb454');
}

// ---- playback: the controls the source takes (hello source.controls), state kept by the viewer
const bar = el('playback'), pauseBtn = el('b-pause'), seekBar = el('seek'), speedSel = el('speed');
let posAt = 0; // performance.now() when stats.position was last set
function setSeekRange(n) {
  stats.sourceFrames = n;
  seekBar.max = String(Math.max(0, n - 1));
  seekBar.disabled = !(n > 0 && stats.controls.includes('seek'));
}
function setupPlayback(src) {
  const c = stats.controls;
  bar.hidden = c.length === 0;
  pauseBtn.hidden = !c.includes('pause') && !c.includes('resume');
  seekBar.hidden = !c.includes('seek');
  el('pos').hidden = !c.includes('seek');
  speedSel.hidden = !c.includes('speed');
  stats.fpsSource = src.fps || 0;
  setSeekRange(Number.isInteger(src.frames) ? src.frames : 0); // hello source.frames
  pauseBtn.textContent = stats.paused ? 'resume' : 'pause';
}
function showPosition() {
  if (!Number.isFinite(stats.position) || !stats.sourceFrames) { el('pos').textContent = '–'; return; }
  let p = stats.position;
  if (!stats.paused) p += (performance.now() - posAt) / 1000 * (stats.fpsSource || 30) * stats.speed;
  p = Math.floor(p) % stats.sourceFrames;
  el('pos').textContent = `${p} / ${stats.sourceFrames}`;
  if (document.activeElement !== seekBar) seekBar.value = String(p);
}
function setPosition(p) {
  if (Number.isFinite(stats.position) && !stats.paused)
    p ??= stats.position + (performance.now() - posAt) / 1000 * (stats.fpsSource || 30) * stats.speed;
  stats.position = p ?? stats.position;
  posAt = performance.now();
}
pauseBtn.addEventListener('click', () => {
  setPosition();
  stats.paused = !stats.paused;
  send({ type: stats.paused ? 'pause' : 'resume' });
  pauseBtn.textContent = stats.paused ? 'resume' : 'pause';
});
seekBar.addEventListener('change', () => {
  const f = Number(seekBar.value);
  send({ type: 'seek', frame: f });
  setPosition(f);
});
speedSel.addEventListener('change', () => {
  setPosition();
  stats.speed = Number(speedSel.value);
  send({ type: 'speed', speed: stats.speed });
});

// ---- capture: a PNG of the view, a WebM clip of it
function download(blob, name) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}
const stamp = () => new Date().toISOString().replace(/[:.]/g, '-');
el('b-shot').addEventListener('click', () => {
  renderer.render(scene, camera);
  renderer.domElement.toBlob(b => {
    if (!b) return;
    stats.screenshots++;
    stats.lastShotBytes = b.size;
    download(b, `meshsteer-${stamp()}.png`);
  }, 'image/png');
});
let recorder = null;
const clipBtn = el('b-clip');
clipBtn.addEventListener('click', () => {
  if (recorder) { recorder.stop(); return; }
  const type = ['video/webm;codecs=vp9', 'video/webm;codecs=vp8', 'video/webm']
    .find(t => window.MediaRecorder && MediaRecorder.isTypeSupported(t));
  if (!type) { stats.errors++; stats.lastError = 'this browser records no WebM'; return; }
  const chunks = [];
  recorder = new MediaRecorder(renderer.domElement.captureStream(30), { mimeType: type });
  recorder.ondataavailable = e => { if (e.data.size) chunks.push(e.data); };
  recorder.onstop = () => {
    const b = new Blob(chunks, { type: 'video/webm' });
    stats.clips++;
    stats.lastClipBytes = b.size;
    stats.lastClipType = type;
    recorder = null;
    clipBtn.textContent = 'record clip';
    clipBtn.classList.remove('on');
    download(b, `meshsteer-${stamp()}.webm`);
  };
  recorder.start(250);
  clipBtn.textContent = 'stop';
  clipBtn.classList.add('on');
});

connect();
requestAnimationFrame(draw);
