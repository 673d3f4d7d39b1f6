// viewer.js - the meshsteer browser viewer: connects to the daemon's /stream (docs/PROTOCOL.md),
// shows the synthesised mesh (lit, orbit camera), the incoming markers as dots, optional colouring
// by model part, and an overlay with fps, end-to-end latency, dropped frames and how many markers
// are bound (its tooltip: which live label drives each). It reconnects by
// itself (the camera is kept) and exposes its counters as window.meshsteer for tests.
import * as THREE from './node_modules/three/build/three.module.js';
import { Orbit } from './orbit.js';
import * as P from './protocol.js';

const params = new URLSearchParams(location.search);
const stats = {
  connected: false, connects: 0, reconnects: 0, hellos: 0, topologies: 0,
  frames: 0,          // frame messages received
  rendered: 0,        // frames drawn
  dropped: 0,         // skipped by the server (slow link) + replaced before they were drawn
  errors: 0, lastError: '',
  latencyMs: NaN,     // capture -> on screen, smoothed; NaN until the clock offset is known
  fps: 0, generation: 0, encoding: params.get('encoding') === 'int16' ? 'int16' : 'float32',
  nv: 0, nf: 0, nm: 0, lastSeq: 0, model: '',
  bound: 0,           // model markers bound to a live label (hello markers[].bound)
  controls: [],       // the source controls the hello offers (source.controls)
};
window.meshsteer = stats;

// ---- three.js scene
const view = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242a);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404650, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(3, 5, 4);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
let dirty = true;
const orbit = new Orbit(camera, renderer.domElement, () => { dirty = true; });
orbit.update();

let mesh = null, points = null, topo = null;
const decoded = { V: null, markers: null, valid: null };
let pending = null; // newest decoded frame header not yet drawn

const partsBox = document.getElementById('c-parts');
const markersBox = document.getElementById('c-markers');
const int16Box = document.getElementById('c-int16');
int16Box.checked = stats.encoding === 'int16';

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
  g.setAttribute('color', new THREE.BufferAttribute(partColours(t.parts, t.nparts), 3));
  g.setIndex(new THREE.BufferAttribute(t.faces, 1));
  g.computeVertexNormals();
  g.computeBoundingSphere();
  const mat = new THREE.MeshStandardMaterial({ color: 0xc9b79c, roughness: 0.6, metalness: 0.0,
                                               vertexColors: partsBox.checked, side: THREE.DoubleSide });
  mesh = new THREE.Mesh(g, mat);
  mesh.frustumCulled = false;
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
  dirty = true;
}

partsBox.addEventListener('change', () => {
  if (mesh) { mesh.material.vertexColors = partsBox.checked; mesh.material.needsUpdate = true; dirty = true; }
});
markersBox.addEventListener('change', () => { if (points) { points.visible = markersBox.checked; dirty = true; } });
int16Box.addEventListener('change', () => {
  stats.encoding = int16Box.checked ? 'int16' : 'float32';
  send({ type: 'encoding', encoding: stats.encoding });
});

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

// ---- the connection
let ws = null, backoff = 500, pingTimer = null;
const status = document.getElementById('status');
function setStatus(text, bad) { status.textContent = text; status.className = bad ? 'bad' : ''; }
function send(obj) { if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj)); }

function connect() {
  const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const token = params.get('token');
  const url = `${proto}//${location.host}/stream${token ? '?token=' + encodeURIComponent(token) : ''}`;
  ws = new WebSocket(url, 'meshsteer.v1');
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => {
    stats.connected = true;
    stats.connects++;
    if (stats.connects > 1) stats.reconnects++;
    backoff = 500;
    bestRtt = Infinity;
    setStatus('connected');
    if (stats.encoding !== 'float32') send({ type: 'encoding', encoding: stats.encoding });
    // The offset is only as good as the shortest round trip seen (its error is at most rtt/2), and
    // the first pings after a connect are slow (the page is still busy): eight pings one after the
    // other (each sent when the previous pong arrives, so a pong always answers the last ping), then
    // one every 2 s.
    pingOpen = false;
    pingBurst = 8;
    ping();
    pingTimer = setInterval(ping, 2000);
  };
  ws.onclose = () => {
    stats.connected = false;
    clearInterval(pingTimer);
    setStatus(`disconnected; retrying in ${(backoff / 1000).toFixed(1)} s`, true);
    setTimeout(connect, backoff);
    backoff = Math.min(backoff * 2, 5000);
  };
  ws.onmessage = ev => {
    try {
      if (typeof ev.data === 'string') onText(JSON.parse(ev.data));
      else onBinary(ev.data);
    } catch (e) {
      stats.errors++;
      stats.lastError = String(e);
      console.error(e);
    }
  };
}

function onText(msg) {
  if (msg.type === 'hello') {
    if (msg.protocol !== P.PROTOCOL) throw new Error(`server speaks protocol ${msg.protocol}`);
    stats.hellos++;
    stats.generation = msg.generation;
    stats.model = msg.model.name;
    stats.nm = msg.markers.length;
    stats.bound = msg.markers.filter(m => m.bound).length;
    stats.controls = Array.isArray(msg.source && msg.source.controls) ? msg.source.controls : [];
    document.getElementById('title').textContent = `meshsteer – ${msg.model.name}`;
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
    buildMesh(topo);
  } else if (k === 'frame' && topo) {
    const h = P.decodeFrame(buf, topo, decoded);
    stats.frames++;
    stats.dropped += h.skipped;
    if (pending) stats.dropped++; // replaced before it was drawn
    stats.lastSeq = h.seq;
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

let fpsCount = 0, fpsT0 = performance.now();
const el = id => document.getElementById(id);
function draw() {
  requestAnimationFrame(draw);
  if (pending && mesh) {
    const pos = mesh.geometry.attributes.position;
    pos.array.set(decoded.V);
    pos.needsUpdate = true;
    mesh.geometry.computeVertexNormals();
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
    fpsCount++;
    dirty = true;
  }
  if (dirty) { renderer.render(scene, camera); dirty = false; }
  const now = performance.now();
  if (now - fpsT0 >= 500) {
    stats.fps = fpsCount * 1000 / (now - fpsT0);
    fpsCount = 0; fpsT0 = now;
    el('o-fps').textContent = stats.fps.toFixed(1);
    el('o-latency').textContent = Number.isNaN(stats.latencyMs) ? '–' : `${stats.latencyMs.toFixed(1)} ms`;
    el('o-dropped').textContent = String(stats.dropped);
    el('o-frames').textContent = String(stats.frames);
    el('o-encoding').textContent = stats.encoding;
  }
}
connect();
requestAnimationFrame(draw);
